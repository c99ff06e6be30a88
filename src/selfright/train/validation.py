"""Checkpoint selection on the benchmark itself: every checkpoint a run saves is evaluated on
its context's grid (deterministic policy, the benchmark's fall protocol and goal set) and the
best one so far is kept as ``model_best.pt``.

Why: off the flat plane the teachers' return keeps rising while their benchmark success
falls (Table I pays for four feet on the ground, not for the goal set), so the last
checkpoint is rarely the best one. Validation uses its own seed (default 1), never the
model card's seed 0, and the same episodes for every checkpoint, so checkpoints are compared
on identical falls and the reported number is not the one the choice was made on.

Files in the run folder::

    validation.csv          iteration, env steps, success rate, successes, episodes
    validation/model_<it>/  the evaluation of each checkpoint (episodes.csv, summary.json)
    model_best.pt           copy of the checkpoint with the highest success so far
"""

from __future__ import annotations

import csv
import shutil
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

from selfright.config import BenchmarkConfig

CSV_FILE = "validation.csv"
BEST_FILE = "model_best.pt"
FIELDS = ("iteration", "env_steps", "success_rate", "successes", "episodes")


@dataclass(frozen=True)
class Score:
    iteration: int
    env_steps: int
    success_rate: float
    successes: int
    episodes: int


def read_scores(run_dir: Path) -> list[Score]:
    """Scores recorded in ``run_dir/validation.csv`` (empty if none)."""
    path = run_dir / CSV_FILE
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return [
            Score(int(r["iteration"]), int(r["env_steps"]), float(r["success_rate"]), int(r["successes"]), int(r["episodes"]))
            for r in csv.DictReader(f)
        ]


def _rate(s: Score) -> Fraction:
    """Exact success rate (the CSV's rounded float would break ties)."""
    return Fraction(s.successes, max(s.episodes, 1))


def best_score(scores: list[Score]) -> Score | None:
    """Highest success rate; ties go to the earlier checkpoint (fewer steps, same evidence)."""
    return max(scores, key=lambda s: (_rate(s), -s.iteration), default=None)


def evaluate_checkpoint(ckpt: Path, grid: str, episodes: int, seed: int, out_dir: Path, bench: BenchmarkConfig) -> Score:
    """Success of checkpoint ``ckpt`` on ``grid`` (``episodes`` per cell, run seed ``seed``)."""
    from selfright.evaluate.runner import evaluate_grid
    from selfright.policies.registry import make_policy
    from selfright.train.checkpoints import CHECKPOINT_RE

    policy = make_policy(str(ckpt), bench)
    res = evaluate_grid(
        policy, policy_name=ckpt.name, grid=grid, episodes=episodes, seed=seed, out_dir=out_dir, cfg=bench, progress=False
    )
    o = res.summary["overall"]
    m = CHECKPOINT_RE.fullmatch(ckpt.name)
    return Score(int(m.group(1)) if m else -1, 0, float(o["success_rate"]), int(o["successes"]), int(o["n"]))


def record(run_dir: Path, score: Score, ckpt: Path) -> bool:
    """Append ``score`` to the run's CSV; copy ``ckpt`` to ``model_best.pt`` if it is the best
    so far. Returns whether it is."""
    previous = best_score(read_scores(run_dir))
    path = run_dir / CSV_FILE
    new_file = not path.exists()
    with path.open("a", newline="") as f:
        w = csv.writer(f)
        if new_file:
            w.writerow(FIELDS)
        w.writerow([score.iteration, score.env_steps, f"{score.success_rate:.4f}", score.successes, score.episodes])
    is_best = previous is None or _rate(score) > _rate(previous)
    if is_best:
        tmp = run_dir / (BEST_FILE + ".tmp")
        shutil.copyfile(ckpt, tmp)
        tmp.replace(run_dir / BEST_FILE)
    return is_best
