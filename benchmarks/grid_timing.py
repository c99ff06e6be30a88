"""Wall-clock of a grid evaluation (target: the `paper` grid at 20 episodes per cell in
≤ 20 minutes on 2 cores). Estimates from a subset of cells unless --full is given.

    python benchmarks/grid_timing.py --policy open-loop [--cells 12] [--full]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from selfright.config import BenchmarkConfig
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.registry import make_policy
from selfright.terrain import grid_cells


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--policy", default="open-loop")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--full", action="store_true", help="run the whole paper grid")
    a = p.parse_args()
    cfg = BenchmarkConfig()
    grid = "paper" if a.full else "quick"
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.time()
        res = evaluate_grid(make_policy(a.policy, cfg), policy_name=a.policy, grid=grid, episodes=a.episodes, seed=0,
                            out_dir=Path(tmp), cfg=cfg, progress=True)
        secs = time.time() - t0
    n_paper = len(grid_cells("paper", cfg.terrain))
    n_run = len(res.summary["cells"])
    est = secs * n_paper / n_run
    print(json.dumps({"grid": grid, "policy": a.policy, "episodes_per_cell": a.episodes, "seconds": round(secs, 1),
                      "paper_grid_estimate_s": round(est, 1), "target_s": 1200, "target_met": est <= 1200}))


if __name__ == "__main__":
    main()
