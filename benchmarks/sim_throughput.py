"""Env-step throughput vs raw MuJoCo physics on the same scene, states and controls.

Target (issue "The self-righting benchmark"): env_over_raw ≥ 0.8, i.e. env logic adds at most
25 % on top of physics. Prints one JSON line per configuration.

    python benchmarks/sim_throughput.py [--seconds 9]
"""

from __future__ import annotations

import argparse
import json

from selfright.benchmark import measure_throughput
from selfright.config import BenchmarkConfig

CASES = [(64, 0, 0), (256, 0, 0), (64, 3, 8), (64, 0, 12)]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__)
    p.add_argument("--seconds", type=float, default=9.0)
    a = p.parse_args()
    for envs, slope, rough in CASES:
        rec = measure_throughput(BenchmarkConfig(), num_envs=envs, seconds=a.seconds, slope_level=slope, roughness_level=rough)
        rec["target_met"] = rec["env_over_raw"] >= 0.8
        print(json.dumps(rec), flush=True)


if __name__ == "__main__":
    main()
