"""Grid evaluation: every (cell, episode) of a named grid, in batches on the batched env,
written as tidy result files. Resumable and deterministic: each episode's randomness comes
from its own seed, derived from (run seed, cell, episode), and physics of one env does not
depend on the others in its batch, so a resumed or re-batched run gives identical rows."""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Iterator, Sequence
from typing import Any, Callable, Literal, Protocol

import numpy as np
import torch
from tqdm import tqdm

from selfright.config import BENCHMARK_VERSION, BenchmarkConfig, ContextConfig, to_dict
from selfright.env.recovery_env import RecoveryEnv, StepOutput
from selfright.env.world import World, build_world
from selfright.evaluate.fall_cache import FallCache, default_cache_dir
from selfright.evaluate.metrics import summarize
from selfright.machine import machine
from selfright.evaluate.results import (
    EpisodeWriter,
    check_run_identity,
    episode_key,
    read_episodes,
    write_canonical,
    write_json,
)
from selfright.policies.base import Policy
from selfright.terrain import Cell, grid_cells


Executor = Literal["local", "ray"]
"""Where a run's batches are simulated: this process, or Ray tasks on a cluster."""


def episode_seed(seed: int, cell: Cell, episode: int) -> int:
    """32-bit seed of one episode, a pure function of the run seed, the cell and the index."""
    key = (cell.slope_level + 1, cell.roughness_level, int(round(cell.slope_pct * 1000)), episode)
    return int(np.random.SeedSequence(entropy=seed, spawn_key=key).generate_state(1)[0])


@dataclass(frozen=True)
class EvalResult:
    out_dir: Path
    summary: dict[str, Any]
    seconds: float
    episodes_run: int


def context_config(cfg: BenchmarkConfig) -> ContextConfig:
    e = cfg.eval
    return ContextConfig(friction=e.friction, wall_gap_ratio=e.wall_gap_ratio, ground_timeconst_s=e.ground_timeconst_s)


def prepare_out_dir(out: Path) -> None:
    """Create ``out`` and make sure it is writable (raises ValueError with advice otherwise)."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".write_test"
        probe.write_text("ok")
        probe.unlink()
    except OSError as e:
        raise ValueError(f"cannot write to --out {out}: {e.strerror or e}; choose a writable directory") from e


def evaluate_grid(
    policy: Policy,
    *,
    policy_name: str,
    grid: str,
    episodes: int,
    seed: int,
    out_dir: Path,
    cfg: BenchmarkConfig,
    progress: bool = True,
    fall_cache: bool = True,
    executor: Executor = "local",
    ray_address: str | None = None,
) -> EvalResult:
    """Run (or resume) a grid evaluation into ``out_dir``; returns the summary.

    ``fall_cache``: read and write settled falls under ``default_cache_dir()`` (the rows are
    the same either way). ``executor``: ``local`` runs the batches here; ``ray`` runs each as
    a Ray task on the cluster at ``ray_address`` (default: a local one), rows written here as
    they arrive (``selfright.evaluate.ray_executor``)."""
    if episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {episodes}")
    cells = grid_cells(grid, cfg.terrain)
    out_dir = Path(out_dir)
    prepare_out_dir(out_dir)
    identity = {"benchmark_version": BENCHMARK_VERSION, "policy": policy_name, "grid": grid, "episodes_per_cell": episodes, "seed": seed, "config": to_dict(cfg)}
    if policy.digest is not None:  # the weights, so a resume never mixes two versions of a named policy
        identity["policy_digest"] = policy.digest
    check_run_identity(out_dir, identity)
    csv_path = out_dir / "episodes.csv"
    order = {(c.slope_level, c.roughness_level): k for k, c in enumerate(cells)}
    existing = [r for r in read_episodes(csv_path) if (r["slope_level"], r["roughness_level"]) in order and r["episode"] < episodes]
    done = {episode_key(r) for r in existing}
    jobs = [(k, e) for k, c in enumerate(cells) for e in range(episodes) if (c.slope_level, c.roughness_level, e) not in done]

    t0 = time.time()
    work = GridWork(cfg=cfg, cells=tuple(cells), seed=seed, num_envs=min(cfg.eval.batch_size, max(len(jobs), 1)),
                    fall_cache_dir=default_cache_dir() if fall_cache else None)
    rows = list(existing)
    if jobs:
        writer = EpisodeWriter(csv_path, existing)
        try:
            rows += run_jobs(work, policy, jobs, writer.write, total=len(cells) * episodes, done=len(done),
                             desc=f"{policy_name} on {grid}", progress=progress, executor=executor,
                             ray_address=ray_address)
        finally:
            writer.close()
    write_canonical(csv_path, rows, order)

    worlds, rough = grid_worlds(cfg, tuple(cells), seed)
    summary = _summary(identity, cells, worlds, rough, rows)
    write_json(out_dir / "summary.json", summary)
    return EvalResult(out_dir=out_dir, summary=summary, seconds=time.time() - t0, episodes_run=len(jobs))


@functools.lru_cache(maxsize=2)
def grid_worlds(cfg: BenchmarkConfig, cells: tuple[Cell, ...], seed: int) -> tuple[list[World], list[float]]:
    """The worlds of ``cells`` (run seed ``seed``) and their tiles' roughness R, built once per
    process for the last two grids (a report evaluates several policies on one grid)."""
    worlds = [build_world(c, cfg, context_config(cfg), seed) for c in cells]
    return worlds, [w.tile.roughness() for w in worlds]


class Work(Protocol):
    """A run's batches of episodes, described so that any process can simulate them: ``open``
    builds what the batches run on, once per process (picklable, hashable: Ray ships it)."""

    def open(self, threads: int | None = None) -> "Session": ...


class Session(Protocol):
    def run(self, policy: Policy, batch: list) -> list[dict[str, Any]]: ...

    def close(self) -> None: ...


def run_batches(
    work: Work, policy: Policy, batches: list[list], executor: Executor = "local", ray_address: str | None = None,
) -> Iterator[list[dict[str, Any]]]:
    """Rows of each batch of ``batches``: in order with ``local``, as Ray tasks finish with ``ray``."""
    if executor == "ray":
        from selfright.evaluate.ray_executor import ray_batches

        yield from ray_batches(work, policy, batches, address=ray_address, num_cpus=work.cfg.sim.threads)
        return
    if executor != "local":
        raise ValueError(f"unknown executor {executor!r}; use local or ray")
    session = work.open()
    try:
        for batch in batches:
            yield session.run(policy, batch)
    finally:
        session.close()


def run_jobs(
    work: Work, policy: Policy, jobs: list, write: Callable[[list[dict[str, Any]]], None], *, total: int, done: int,
    desc: str, progress: bool, executor: Executor = "local", ray_address: str | None = None,
) -> list[dict[str, Any]]:
    """Run ``jobs`` in batches of ``work.num_envs`` (``run_batches``), handing each batch's rows
    to ``write`` as it finishes, under a progress bar of ``total`` episodes (``done`` already
    finished); returns the new rows."""
    batches = [jobs[b : b + work.num_envs] for b in range(0, len(jobs), work.num_envs)]
    bar = tqdm(total=total, initial=done, desc=desc, unit="ep", disable=not progress)
    rows: list[dict[str, Any]] = []
    try:
        for new in run_batches(work, policy, batches, executor, ray_address):
            write(new)
            rows.extend(new)
            bar.update(len(new))
    finally:
        bar.close()
    return rows


@dataclass(frozen=True)
class GridWork:
    """The batches of a grid evaluation: every cell's world, one env of ``num_envs`` slots."""

    cfg: BenchmarkConfig
    cells: tuple[Cell, ...]
    seed: int
    num_envs: int
    fall_cache_dir: Path | None
    """Settled falls are read from and written to this cache (``FallCache``); None = settle every fall."""

    def open(self, threads: int | None = None) -> GridSession:
        return GridSession(self, threads)


class GridSession:
    """What a process simulates a grid's batches on: worlds, env, fall cache."""

    def __init__(self, work: GridWork, threads: int | None = None):
        self.work = work
        self.worlds, self.rough = grid_worlds(work.cfg, work.cells, work.seed)
        self.env = RecoveryEnv(work.cfg, self.worlds, work.num_envs, threads)
        self.falls = None if work.fall_cache_dir is None else FallCache(work.fall_cache_dir, work.cfg)

    def run(self, policy: Policy, batch: list[tuple[int, int]]) -> list[dict[str, Any]]:
        w = self.work
        return _run_batch(self.env, policy, batch, list(w.cells), self.worlds, self.rough, w.seed, self.falls)

    def close(self) -> None:
        self.env.close()


def rollout_batch(
    env: RecoveryEnv, policy: Policy, cell_index: np.ndarray, seeds: np.ndarray, cells: list[Cell],
    on_step: Callable[[np.ndarray, StepOutput], None] | None = None,
    on_start: Callable[[], None] | None = None,
    falls: FallCache | None = None,
    fall_keys: Sequence[str] = (),
) -> np.ndarray:
    """Reset env slots ``0..n-1`` to the falls of ``seeds`` on the worlds ``cell_index`` (grid
    cells ``cells``, one per slot) and run ``policy`` until every episode is done; returns which
    episodes succeeded. ``on_start()``
    runs once the falls have settled, ``on_step(active, out)`` sees each control step's output
    for the slots still running (diagnostics). With ``falls``, the settled starts named
    ``fall_keys`` (one per slot, ``FallCache.key``) are read from the cache where present."""
    if env.cfg.eval.sensor_noise > 0:
        from selfright.policies.sensor_noise import NoisySensors

        policy = NoisySensors(policy, env.cfg.eval.sensor_noise, env.robot.num_joints)
    ids = np.arange(len(seeds))
    rngs = [np.random.default_rng(s) for s in seeds]
    if falls is None:
        env.reset(ids, cell_index, rngs)
    else:
        starts = falls.settle(env, cell_index, rngs, fall_keys)
        env.begin(ids, cell_index, [env.worlds[w].model for w in cell_index], starts)
    if on_start is not None:
        on_start()
    policy.reset(ids, seeds)
    success = np.zeros(len(seeds), dtype=bool)
    active = ids[~env.diverged[torch.from_numpy(ids)].numpy()]
    while len(active):
        obs = env.observe(active, policy.groups)
        with torch.no_grad():
            actions = policy.act(obs, active, [cells[i] for i in active])
        out = env.step(actions, active)
        if on_step is not None:
            on_step(active, out)
        success[active[out.succeeded.numpy()]] = True
        active = active[~out.done.numpy()]
    return success


def _run_batch(
    env: RecoveryEnv, policy: Policy, batch: list[tuple[int, int]], cells: list[Cell], worlds: list[World],
    rough: list[float], seed: int, falls: FallCache | None = None,
) -> list[dict[str, Any]]:
    """Simulate one batch of episodes to completion; returns their rows."""
    ids = np.arange(len(batch))
    seeds = np.array([episode_seed(seed, cells[k], e) for k, e in batch], dtype=np.int64)
    keys = [falls.key(worlds[k], seed, e, int(seeds[i])) for i, (k, e) in enumerate(batch)] if falls else ()
    success = rollout_batch(env, policy, np.array([k for k, _ in batch]), seeds, [cells[k] for k, _ in batch],
                            falls=falls, fall_keys=keys)
    m = env.metrics(ids)
    rows = []
    for i, (k, e) in enumerate(batch):
        c = cells[k]
        ok = bool(success[i])
        rows.append({
            "slope_level": c.slope_level, "roughness_level": c.roughness_level,
            "slope_pct": c.slope_pct, "slope_deg": c.slope_deg, "roughness_R": rough[k],
            "friction": worlds[k].context.friction, "episode": e, "seed": int(seeds[i]), "success": ok,
            "ttr_s": float(m["ttr_s"][i]) if ok else None, "dtr_m": float(m["dtr_m"][i]) if ok else None,
            "energy_j": float(m["energy_j"][i]), "peak_ang_speed": float(m["peak_ang_speed"][i]),
            "diverged": bool(m["diverged"][i]),
        })
    return rows


def _summary(identity, cells, worlds, rough, rows) -> dict[str, Any]:
    by_cell: dict[tuple[int, int], list[dict[str, Any]]] = {}
    for r in rows:
        by_cell.setdefault((r["slope_level"], r["roughness_level"]), []).append(r)
    out_cells = []
    for k, c in enumerate(cells):
        stats = summarize(by_cell.get((c.slope_level, c.roughness_level), []))
        out_cells.append({
            "slope_level": c.slope_level, "roughness_level": c.roughness_level, "slope_pct": c.slope_pct,
            "slope_deg": c.slope_deg, "roughness_extent_m": c.roughness_extent_m, "roughness_R": rough[k],
            "friction": worlds[k].context.friction, **stats,
        })
    # The machine: rows are byte-identical on one machine, not across CPU generations (docs/benchmark.md, *Seeds and determinism*).
    return {**identity, "machine": machine(), "cells": out_cells, "overall": summarize(rows)}


def format_table(summary: dict[str, Any], max_rows: int = 40) -> str:
    """Compact text table of the per-cell results plus the overall line."""
    lines = [f"{'slope':>6} {'rough':>5} {'R':>7} {'n':>4} {'success':>8} {'ci95':>13} {'TTR s':>6} {'DTR m':>6}"]

    def fmt(v: float | None, p: str) -> str:
        return "  N/A" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, p)

    cells = summary["cells"]
    shown = cells if len(cells) <= max_rows else cells[:max_rows]
    for c in shown:
        lo, hi = c["success_ci95"]
        lines.append(
            f"{c['slope_pct']:5.0f}% {c['roughness_level']:5d} {c['roughness_R']:7.1f} {c['n']:4d} "
            f"{100 * c['success_rate']:7.1f}% [{100 * lo:4.0f},{100 * hi:4.0f}]% {fmt(c['ttr_mean_s'], '6.2f')} {fmt(c['dtr_mean_m'], '6.2f')}"
        )
    if len(cells) > max_rows:
        lines.append(f"... {len(cells) - max_rows} more cells in summary.json")
    o = summary["overall"]
    lo, hi = o["success_ci95"]
    lines.append(
        f"overall: {o['n']} episodes, success {100 * o['success_rate']:.1f}% [{100 * lo:.0f}, {100 * hi:.0f}]%, "
        f"TTR {fmt(o['ttr_mean_s'], '.2f')} s, DTR {fmt(o['dtr_mean_m'], '.2f')} m, diverged {o['diverged']}"
    )
    return "\n".join(lines)
