"""Evaluation at scale, in one run: the fall cache cold vs warm (target: warm ≤ 0.8 × cold for
``sr`` on the quick grid) and the Ray executor's overhead over the local one with 1 and 2
workers (``--executor ray`` on a local Ray; every run on a warm cache, so only the executor
differs). Each run writes into a fresh folder; the cache lives in a temporary
``XDG_CACHE_HOME``. Needs ``pip install -e ".[ray]"`` for the Ray rows (skipped otherwise).

    python benchmarks/eval_scale.py [--grid paper] [--policy sr] [--episodes 20]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import tempfile
import time
from pathlib import Path

from selfright.config import BenchmarkConfig, SimConfig
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.registry import make_policy


def timed(a: argparse.Namespace, tmp: Path, name: str, threads: int, **kw) -> float:
    cfg = BenchmarkConfig(sim=SimConfig(threads=threads))
    t0 = time.perf_counter()
    evaluate_grid(make_policy(a.policy, cfg), policy_name=a.policy, grid=a.grid, episodes=a.episodes, seed=0,
                  out_dir=tmp / name, cfg=cfg, progress=False, **kw)
    secs = time.perf_counter() - t0
    print(f"{name:>22}: {secs:8.1f} s", flush=True)
    return secs


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--grid", default="paper", choices=["tiny", "quick", "paper", "flat", "rough", "incline"])
    p.add_argument("--policy", default="sr")
    p.add_argument("--episodes", type=int, default=20)
    a = p.parse_args()
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        os.environ["XDG_CACHE_HOME"] = str(tmp / "cache")
        cold = timed(a, tmp, "local 1 thread, cold", 1)
        warm = timed(a, tmp, "local 1 thread, warm", 1)
        local2 = timed(a, tmp, "local 2 threads, warm", 2)
        out = {"grid": a.grid, "policy": a.policy, "episodes_per_cell": a.episodes, "cold_s": round(cold, 2),
               "warm_s": round(warm, 2), "warm_over_cold": round(warm / cold, 3), "local_2_threads_s": round(local2, 2)}
        if importlib.util.find_spec("ray") is None:
            print('Ray rows skipped: pip install -e ".[ray]"')
        else:
            ray1 = timed(a, tmp, "ray 1 worker, warm", 1, executor="ray")
            ray2 = timed(a, tmp, "ray 2 workers, warm", 2, executor="ray")
            out.update({"ray_1_worker_s": round(ray1, 2), "ray_1_overhead_pct": round(100 * (ray1 / warm - 1), 1),
                        "ray_2_workers_s": round(ray2, 2), "ray_2_overhead_pct": round(100 * (ray2 / local2 - 1), 1)})
    print(json.dumps(out))


if __name__ == "__main__":
    main()
