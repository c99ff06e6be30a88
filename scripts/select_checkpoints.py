"""Score many training checkpoints on the same falls and rank them: model selection on
selection seeds, to be confirmed on seeds that chose nothing.

A run's checkpoints differ more than the falls alone explain (checkpoints a few iterations
apart disagree on a fifth of the falls: docs/training.md), so the last checkpoint is one draw
among them. This scores every candidate on the same
selection seeds, each policy loaded once for all of them, and prints them best first with
their pooled rate and 95 % Wilson interval. The top of such a ranking is biased upward by the
pick itself: score the chosen few again on fresh seeds with ``selfright evaluate`` and pair
them with ``selfright compare`` before trusting the number.

    python scripts/select_checkpoints.py runs/A runs/B/model_300.pt --grid incline --seeds 4 5 6 7 8 9 10 11 --out results/select

A run folder stands for its numbered checkpoints (``model_K.pt``, K > 0; ``--every`` thins
them); results go to ``OUT/<run>_<K>/s<seed>`` as ``selfright evaluate`` writes them, and a
folder that already holds a summary is read, not simulated again (rerun to resume).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path

import tyro

from selfright.config import BenchmarkConfig
from selfright.evaluate.metrics import wilson_interval
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.registry import make_policy
from selfright.policies.run_files import CHECKPOINT_RE, list_checkpoints


@dataclass(frozen=True)
class Args:
    candidates: tyro.conf.Positional[tuple[Path, ...]]
    """Training checkpoints (``model_K.pt``) or run folders (all their numbered checkpoints)."""
    out: Path
    """Results root: one folder per candidate and seed."""
    grid: str = "incline"
    seeds: tuple[int, ...] = (4, 5, 6, 7, 8, 9, 10, 11)
    """Selection seeds (the project's convention for the incline: 4–11; never seed 0, the bar's)."""
    episodes: int = 64
    every: int = 1
    """Of a run folder's checkpoints, keep every this many (the last always)."""
    min_iteration: int = 1
    """Skip a run folder's checkpoints before this iteration."""
    threads: int = 0
    """Physics worker threads; 0 = one per CPU core."""


def _iteration(path: Path) -> int:
    m = CHECKPOINT_RE.fullmatch(path.name)
    if m is None:
        raise ValueError(f"{path} is not a numbered training checkpoint (model_K.pt)")
    return int(m.group(1))


def expand(candidates: tuple[Path, ...], every: int = 1, min_iteration: int = 1) -> list[Path]:
    """The checkpoints the candidates name, in order, each once: a file as it is, a run folder as
    its numbered checkpoints from ``min_iteration`` on, every ``every``-th and the last."""
    if every < 1:
        raise ValueError(f"--every is at least 1, got {every}")
    out: list[Path] = []
    for c in candidates:
        if c.is_dir():
            found = [p for k, p in list_checkpoints(c) if k >= max(1, min_iteration)]
            if not found:
                raise ValueError(f"{c} holds no numbered checkpoint at or after iteration {min_iteration}")
            out += [p for i, p in enumerate(found) if i % every == 0 or i == len(found) - 1]
        elif c.is_file():
            _iteration(c)
            out.append(c)
        else:
            raise ValueError(f"{c} is neither a checkpoint nor a run folder")
    seen: set[Path] = set()
    return [p for p in out if not (p.resolve() in seen or seen.add(p.resolve()))]


def label(checkpoint: Path) -> str:
    """``<run folder>_<iteration>``: the name of a candidate's results folder."""
    return f"{checkpoint.parent.name}_{_iteration(checkpoint)}"


def score(checkpoint: Path, a: Args, cfg: BenchmarkConfig) -> tuple[int, int]:
    """(successes, episodes) of one candidate over the selection seeds, simulating only the
    seeds whose results folder holds no summary yet."""
    k = n = 0
    policy = None
    for seed in a.seeds:
        folder = a.out / label(checkpoint) / f"s{seed}"
        summary = folder / "summary.json"
        if not summary.exists():
            policy = policy or make_policy(str(checkpoint), cfg)
            evaluate_grid(policy, policy_name=str(checkpoint), grid=a.grid, episodes=a.episodes, seed=seed,
                          out_dir=folder, cfg=cfg, progress=False)
        o = json.loads(summary.read_text())["overall"]
        k, n = k + round(o["success_rate"] * o["n"]), n + int(o["n"])
    return k, n


def main(a: Args) -> None:
    if not a.seeds:
        raise SystemExit("select_checkpoints: give --seeds")
    try:
        checkpoints = expand(a.candidates, a.every, a.min_iteration)
    except ValueError as e:
        raise SystemExit(f"select_checkpoints: {e}") from None
    cfg = BenchmarkConfig()
    cfg = replace(cfg, sim=replace(cfg.sim, threads=a.threads))
    rows = []
    for i, c in enumerate(checkpoints, 1):
        k, n = score(c, a, cfg)
        rows.append((k / n, k, n, c))
        print(f"[{i}/{len(checkpoints)}] {c}: {k} / {n} = {100 * k / n:.1f} %", flush=True)
    print(f"\nranked on {a.grid}, seeds {' '.join(map(str, a.seeds))} (biased upward at the top by the pick):")
    for rate, k, n, c in sorted(rows, key=lambda r: -r[0]):
        lo, hi = wilson_interval(k, n)
        print(f"  {100 * rate:5.1f} %  [{100 * lo:.0f}, {100 * hi:.0f}]  {k:4d} / {n:4d}  {c}")


if __name__ == "__main__":
    main(tyro.cli(Args))
