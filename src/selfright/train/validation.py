"""Checkpoint selection on the benchmark itself: every checkpoint a run saves is evaluated on
its context's grid (deterministic policy, the benchmark's fall protocol and goal set) and the
best one so far is kept as ``model_best.pt``.

Why: off the flat plane the teachers' return keeps rising while their benchmark success
falls (Table I pays for four feet on the ground, not for the goal set), so the last
checkpoint is rarely the best one. Validation uses its own seed (default 1), never the
model card's seed 0, and the same episodes for every checkpoint, so checkpoints are compared
on identical falls and the reported number is not the one the choice was made on. A student
trained under sensor noise (``RandomizationConfig.sensor_noise``) is validated under the same
noise (``EvalConfig.sensor_noise``, recorded in each ``summary.json``).

Files in the run folder::

    validation.csv          iteration, env steps, success rate, successes, episodes
    validation/model_<it>/  the evaluation of each checkpoint (episodes.csv, summary.json)
    model_best.pt           copy of the checkpoint with the highest success so far
"""

from __future__ import annotations

import csv
import shutil
from dataclasses import dataclass
from pathlib import Path

from selfright.config import BenchmarkConfig

CSV_FILE = "validation.csv"
BEST_FILE = "model_best.pt"
FIELDS = ("iteration", "env_steps", "success_rate", "successes", "episodes")


@dataclass(frozen=True)
class Score:
    iteration: int
    env_steps: int
    successes: int
    episodes: int

    @property
    def success_rate(self) -> float:
        """From the counts, so equal fractions compare equal (the CSV's rounded column is for
        reading only)."""
        return self.successes / max(self.episodes, 1)


def read_scores(run_dir: Path) -> list[Score]:
    """Scores recorded in ``run_dir/validation.csv`` (empty if none)."""
    path = run_dir / CSV_FILE
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return [
            Score(int(r["iteration"]), int(r["env_steps"]), int(r["successes"]), int(r["episodes"]))
            for r in csv.DictReader(f)
        ]


def best_score(scores: list[Score]) -> Score | None:
    """Highest success rate; ties go to the earlier checkpoint (fewer steps, same evidence)."""
    return max(scores, key=lambda s: (s.success_rate, -s.iteration), default=None)


def evaluate_checkpoint(
    ckpt: Path,
    *,
    iteration: int,
    env_steps: int,
    grid: str,
    episodes: int,
    seed: int,
    out_dir: Path,
    bench: BenchmarkConfig,
) -> Score:
    """Success of checkpoint ``ckpt`` (saved after ``iteration``, ``env_steps``) on ``grid``
    (``episodes`` per cell, run seed ``seed``)."""
    from selfright.evaluate.runner import evaluate_grid
    from selfright.policies.registry import make_policy

    policy = make_policy(str(ckpt), bench)
    res = evaluate_grid(
        policy, policy_name=ckpt.name, grid=grid, episodes=episodes, seed=seed, out_dir=out_dir, cfg=bench, progress=False,
    )
    o = res.summary["overall"]
    return Score(iteration, env_steps, int(o["successes"]), int(o["n"]))


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
    is_best = previous is None or score.success_rate > previous.success_rate
    if is_best:
        tmp = run_dir / (BEST_FILE + ".tmp")
        shutil.copyfile(ckpt, tmp)
        tmp.replace(run_dir / BEST_FILE)
    return is_best
