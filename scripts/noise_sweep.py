"""Success against sensor-noise scale: each policy evaluated on one grid at several
``--sensor-noise`` scales (the same falls at every scale), one results folder per point
(``OUT/<policy>/noise<S>/s<seed>``, resumable like ``selfright evaluate``), then a table of the
pooled success with its 95 % Wilson interval. Scale 1 is ``SENSOR_NOISE_STD`` as Gaussian
standard deviations (about 1.7 times legged_gym's uniform noise; 0.58 matches its spread).

    python scripts/noise_sweep.py --policies incline incline-sensor-noise --grid incline --seeds 4 --out results/noise_sweep
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path

import tyro

from selfright.config import BenchmarkConfig
from selfright.evaluate.metrics import wilson_interval
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.registry import make_policy


@dataclass(frozen=True)
class Args:
    policies: tuple[str, ...]
    """Policy names or files, as ``selfright evaluate --policy`` takes them."""
    grid: str = "incline"
    """Named grid (``flat``, ``rough``, ``incline``, ``quick``, ...)."""
    scales: tuple[float, ...] = (0.0, 0.25, 0.5, 1.0, 1.5)
    """Sensor-noise scales (0 = the benchmark's exact sensors)."""
    seeds: tuple[int, ...] = (4,)
    """Evaluation seeds (the same falls at every scale and for every policy)."""
    episodes: int = 64
    """Episodes per grid cell."""
    threads: int = 1
    """Physics threads."""
    out: Path = Path("results/noise_sweep")
    """Folder of the results folders."""


def sweep(args: Args) -> dict[str, dict[float, tuple[int, int]]]:
    """{policy: {scale: (successes, episodes)}}, evaluating whatever is not on disk yet."""
    base = BenchmarkConfig()
    base = dataclasses.replace(base, sim=dataclasses.replace(base.sim, threads=args.threads))
    table: dict[str, dict[float, tuple[int, int]]] = {}
    for name in args.policies:
        for scale in args.scales:
            cfg = dataclasses.replace(base, eval=dataclasses.replace(base.eval, sensor_noise=scale))
            k = n = 0
            for seed in args.seeds:
                out = args.out / Path(name).stem / f"noise{scale:g}" / f"s{seed}"
                if not (out / "summary.json").exists():
                    evaluate_grid(make_policy(name, cfg), policy_name=name, grid=args.grid, episodes=args.episodes,
                                  seed=seed, out_dir=out, cfg=cfg, progress=False)
                o = json.loads((out / "summary.json").read_text())["overall"]
                k, n = k + o["successes"], n + o["n"]
            table.setdefault(name, {})[scale] = (k, n)
    return table


def main(args: Args) -> None:
    table = sweep(args)
    print(f"success on --grid {args.grid}, seeds {', '.join(map(str, args.seeds))} (95 % Wilson interval)")
    print("| policy | " + " | ".join(f"noise {s:g}" for s in args.scales) + " |")
    print("|---|" + "---:|" * len(args.scales))
    for name, row in table.items():
        cells = []
        for s in args.scales:
            k, n = row[s]
            lo, hi = wilson_interval(k, n)
            cells.append(f"{100 * k / n:.1f} % [{100 * lo:.0f}, {100 * hi:.0f}]")
        print(f"| `{name}` | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(tyro.cli(Args))
