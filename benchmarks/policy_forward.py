"""Cost of batch-independent actions: a shipped actor's ``forward_rows`` (each env's action
computed on its own, so results do not depend on the batch) against the plain batched
``forward``, side by side, and the difference as a share of one env step of the same batch
(64 envs on the flat tile, physics and env logic).

    python benchmarks/policy_forward.py [--policy flat] [--batches 1 64 512] [--seconds 3]

Prints one JSON line per batch size.
"""

from __future__ import annotations

import argparse
import json
import time

import torch

from selfright.benchmark import measure_throughput
from selfright.config import BenchmarkConfig
from selfright.policies.actor import load_actor_file
from selfright.policies.registry import shipped_path


def per_call_us(fn, x: torch.Tensor, seconds: float) -> float:
    with torch.no_grad():
        for _ in range(10):
            fn(x)
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            fn(x)
            n += 1
    return 1e6 * (time.perf_counter() - t0) / n


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--policy", default="flat", help="shipped policy name")
    p.add_argument("--batches", type=int, nargs="+", default=[1, 64, 512])
    p.add_argument("--seconds", type=float, default=3.0)
    a = p.parse_args()
    actor = load_actor_file(shipped_path(a.policy))
    env = measure_throughput(BenchmarkConfig(), num_envs=64, seconds=a.seconds, slope_level=0, roughness_level=0)
    step_us_64 = 1e6 * 64 / env["env_steps_per_s"]
    for b in a.batches:
        x = torch.randn(b, actor.meta.obs_dim, generator=torch.Generator().manual_seed(0))
        plain = per_call_us(actor.forward, x, a.seconds)
        rows = per_call_us(actor.forward_rows, x, a.seconds)
        rec = {"policy": a.policy, "batch": b, "forward_us": round(plain, 1), "forward_rows_us": round(rows, 1),
               "rows_over_forward": round(rows / plain, 2), "threads": torch.get_num_threads()}
        if b == 64:
            rec["env_step_us_64_envs"] = round(step_us_64, 1)
            rec["extra_share_of_env_step"] = round((rows - plain) / step_us_64, 3)
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
