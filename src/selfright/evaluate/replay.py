"""Replay one benchmark episode and record it: the same fall, terrain and policy as the
matching row of ``selfright evaluate``'s ``episodes.csv`` (same run seed, cell and episode
index), simulated alone, with its state after every control step kept for inspection.

Writes into one folder: ``trajectory.npz`` (full MuJoCo physics states, 50 Hz),
``scene.xml`` (the cell's model: replays render without rebuilding the terrain),
``trace.csv`` (what the goal set reads, per control step) and ``replay.json`` (identity and
outcome). ``selfright.evaluate.render`` turns the first two into a video and a filmstrip;
``selfright.plots.trace`` plots the third.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from selfright.config import BENCHMARK_VERSION, BenchmarkConfig, to_dict
from selfright.env.goal import goal_height_m, robot_in_goal_set
from selfright.env.recovery_env import RecoveryEnv, StepOutput
from selfright.env.robot_state import RobotState
from selfright.env.world import build_world
from selfright.evaluate.fall_cache import FallCache, default_cache_dir
from selfright.evaluate.results import write_json
from selfright.evaluate.runner import context_config, episode_seed, prepare_out_dir, rollout_batch
from selfright.policies.base import Policy
from selfright.terrain import Cell, grid_cells

TRACE_COLUMNS = (
    "t_s", "x_m", "y_m", "z_m", "height_over_feet_m", "height_over_terrain_m", "roll_deg", "pitch_deg",
    "feet_down", "body_contacts", "in_goal",
)
"""Columns of ``trace.csv``: time since policy start, trunk position (world), body height over the
feet (the goal set's, ``RobotState.height_over_feet``) and, for comparison, over the ground
beneath the trunk, roll and pitch relative to gravity, feet and other bodies touching the
ground, and whether the state is in the goal set."""


@dataclass(frozen=True)
class Replay:
    """One recorded episode."""

    cell: Cell
    episode: int
    episode_seed: int
    states: np.ndarray
    """(T + 1, nstate) full-physics states: the settled fall, then one per control step."""
    trace: dict[str, np.ndarray]
    """``TRACE_COLUMNS`` -> (T + 1,) arrays."""
    success: bool
    ttr_s: float | None
    dtr_m: float | None
    diverged: bool
    scene_xml: str
    goal_height_m: float
    """The goal set's body-height bar (m)."""
    hold_min_height_over_feet_m: float | None
    """Lowest body height over the feet through the successful hold (m); None: no success."""


def select_cell(grid: str, cfg: BenchmarkConfig, slope_level: int | None, roughness_level: int | None) -> Cell:
    """The one cell of ``grid`` with the given levels (either may be omitted if unambiguous)."""
    cells = grid_cells(grid, cfg.terrain)
    hits = [
        c for c in cells
        if (slope_level is None or c.slope_level == slope_level)
        and (roughness_level is None or c.roughness_level == roughness_level)
    ]
    if len(hits) != 1:
        listed = ", ".join(f"(--slope-level {c.slope_level} --roughness-level {c.roughness_level})" for c in cells[:12])
        more = f" and {len(cells) - 12} more" if len(cells) > 12 else ""
        what = "no cell" if not hits else f"{len(hits)} cells"
        raise ValueError(f"{what} of grid {grid!r} match; pick one of {listed}{more}")
    return hits[0]


def _trace_row(rs: RobotState, in_goal: torch.Tensor, t_s: float) -> dict[str, float]:
    pos = rs.pos[0].double().numpy()
    return {
        "t_s": t_s, "x_m": float(pos[0]), "y_m": float(pos[1]), "z_m": float(pos[2]),
        "height_over_feet_m": float(rs.height_over_feet[0]),
        "height_over_terrain_m": float(rs.height_over_terrain[0]), "roll_deg": math.degrees(float(rs.roll[0])),
        "pitch_deg": math.degrees(float(rs.pitch[0])), "feet_down": int(rs.feet_contact[0].sum()),
        "body_contacts": int(rs.body_contacts[0]), "in_goal": int(bool(in_goal[0])),
    }


def replay_episode(policy: Policy, cfg: BenchmarkConfig, cell: Cell, episode: int, seed: int, fall_cache: bool = True) -> Replay:
    """Simulate episode ``episode`` of ``cell`` (run seed ``seed``) as the evaluator does
    (its settled fall read from the fall cache unless ``fall_cache`` is False)."""
    if episode < 0:
        raise ValueError(f"--episode must be >= 0, got {episode}")
    world = build_world(cell, cfg, context_config(cfg), seed)
    env = RecoveryEnv(cfg, [world], 1)
    ep_seed = episode_seed(seed, cell, episode)
    states: list[np.ndarray] = []
    rows: list[dict[str, float]] = []
    slot = np.zeros(1, dtype=np.int64)
    try:
        def start() -> None:
            rs = env.robot_state(slot)
            goal = robot_in_goal_set(rs, cfg.goal, env.robot.leg_length_m)
            states.append(env.state[0].copy())
            rows.append(_trace_row(rs, goal, 0.0))

        def record(active: np.ndarray, out: StepOutput) -> None:
            states.append(env.state[0].copy())
            rows.append(_trace_row(out.state, out.in_goal, float(env.step_count[0]) * env.control_dt))

        falls = FallCache(default_cache_dir(), cfg) if fall_cache else None
        keys = [falls.key(world, seed, episode, ep_seed)] if falls else ()
        success = rollout_batch(env, policy, slot, np.array([ep_seed]), [cell], record, start, falls, keys)
        m = env.metrics(slot)
    finally:
        env.close()
    ok = bool(success[0])
    trace = {k: np.array([r[k] for r in rows]) for k in TRACE_COLUMNS}
    hold = int(round(cfg.goal.hold_s / env.control_dt))  # a success ends its episode with its hold
    hold_min = float(trace["height_over_feet_m"][-hold:].min()) if ok else None
    return Replay(
        cell=cell, episode=episode, episode_seed=ep_seed, states=np.stack(states), trace=trace,
        success=ok, ttr_s=float(m["ttr_s"][0]) if ok else None, dtr_m=float(m["dtr_m"][0]) if ok else None,
        diverged=bool(m["diverged"][0]), scene_xml=world.xml,
        goal_height_m=goal_height_m(cfg.goal, env.robot.leg_length_m), hold_min_height_over_feet_m=hold_min,
    )


def write_replay(out_dir: Path, r: Replay, identity: dict[str, Any], cfg: BenchmarkConfig) -> None:
    """Write ``trajectory.npz``, ``scene.xml``, ``trace.csv`` and ``replay.json`` into ``out_dir``."""
    out_dir = Path(out_dir)
    prepare_out_dir(out_dir)
    np.savez_compressed(out_dir / "trajectory.npz", states=r.states, t_s=r.trace["t_s"], control_dt_s=cfg.sim.control_dt_s)
    (out_dir / "scene.xml").write_text(r.scene_xml)
    with open(out_dir / "trace.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(TRACE_COLUMNS)
        for i in range(len(r.trace["t_s"])):
            w.writerow([_fmt(r.trace[k][i]) for k in TRACE_COLUMNS])
    c = r.cell
    write_json(out_dir / "replay.json", {
        "benchmark_version": BENCHMARK_VERSION, **identity, "slope_level": c.slope_level, "roughness_level": c.roughness_level, "slope_pct": c.slope_pct,
        "roughness_extent_m": c.roughness_extent_m, "episode": r.episode,
        "episode_seed": r.episode_seed, "success": r.success, "ttr_s": r.ttr_s, "dtr_m": r.dtr_m,
        "diverged": r.diverged, "control_steps": len(r.states) - 1,
        "goal_height_m": r.goal_height_m, "goal_height_ref": cfg.goal.height_ref,
        "hold_min_height_over_feet_m": r.hold_min_height_over_feet_m, "max_tilt_deg": cfg.goal.max_tilt_deg,
        "hold_s": cfg.goal.hold_s, "config": to_dict(cfg),
    })


def _fmt(v: Any) -> str:
    return f"{float(v):.6g}" if isinstance(v, (float, np.floating)) else str(v)
