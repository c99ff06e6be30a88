"""Success against one of the benchmark's further factors: each policy evaluated on one grid at
several values of ``--factor`` (sensor noise, ground friction, side walls, ground compliance;
the same falls at every value), one results folder per point
(``OUT/<policy>/<factor><value>/s<seed>``, resumable like ``selfright evaluate``), then a table of
the pooled success with its 95 % Wilson interval.

    python scripts/factor_sweep.py --policies incline sr --grid incline --seeds 4 --out results/noise_sweep
    python scripts/factor_sweep.py --factor friction --values 0.4 0.6 0.8 1.0 1.2 --policies flat --grid flat --seeds 0

Sensor noise (the default factor): scale 1 is ``SENSOR_NOISE_STD`` as Gaussian standard deviations
(about 1.7 times legged_gym's uniform noise; 0.58 matches its spread). Walls: the gap between two
side walls in body lengths, 0 for none. Ground compliance: the contact time constant (s), larger
is softer (the benchmark's 0.02).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import tyro

from selfright.config import BenchmarkConfig
from selfright.evaluate.metrics import wilson_interval
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.registry import make_policy

Factor = Literal["sensor_noise", "friction", "wall_gap_ratio", "ground_timeconst_s"]
LABELS = {"sensor_noise": "noise", "friction": "friction", "wall_gap_ratio": "walls", "ground_timeconst_s": "ground"}
"""Each factor's name in the folder names and the table's header."""


@dataclass(frozen=True)
class Args:
    policies: tuple[str, ...]
    """Policy names or files, as ``selfright evaluate --policy`` takes them."""
    grid: str = "incline"
    """Named grid (``flat``, ``rough``, ``incline``, ``quick``, ...)."""
    factor: Factor = "sensor_noise"
    """The ``EvalConfig`` field swept (``selfright evaluate``'s ``--sensor-noise``, ``--friction``,
    ``--wall-gap-ratio``, ``--ground-timeconst``)."""
    values: tuple[float, ...] = (0.0, 0.25, 0.5, 1.0, 1.5)
    """The factor's values (walls: 0 = none)."""
    seeds: tuple[int, ...] = (4,)
    """Evaluation seeds (the same falls at every value and for every policy)."""
    episodes: int = 64
    """Episodes per grid cell."""
    threads: int = 1
    """Physics threads."""
    out: Path = Path("results/factor_sweep")
    """Folder of the results folders."""


def config_at(base: BenchmarkConfig, factor: str, value: float) -> BenchmarkConfig:
    """``base`` with the evaluation's ``factor`` set to ``value`` (walls: 0 = none)."""
    v = None if factor == "wall_gap_ratio" and value <= 0 else value
    return dataclasses.replace(base, eval=dataclasses.replace(base.eval, **{factor: v}))


def sweep(args: Args) -> dict[str, dict[float, tuple[int, int]]]:
    """{policy: {value: (successes, episodes)}}, evaluating whatever is not on disk yet."""
    base = BenchmarkConfig()
    base = dataclasses.replace(base, sim=dataclasses.replace(base.sim, threads=args.threads))
    table: dict[str, dict[float, tuple[int, int]]] = {}
    for name in args.policies:
        for value in args.values:
            cfg = config_at(base, args.factor, value)
            k = n = 0
            for seed in args.seeds:
                out = args.out / Path(name).stem / f"{LABELS[args.factor]}{value:g}" / f"s{seed}"
                if not (out / "summary.json").exists():
                    evaluate_grid(make_policy(name, cfg), policy_name=name, grid=args.grid, episodes=args.episodes,
                                  seed=seed, out_dir=out, cfg=cfg, progress=False)
                o = json.loads((out / "summary.json").read_text())["overall"]
                k, n = k + o["successes"], n + o["n"]
            table.setdefault(name, {})[value] = (k, n)
    return table


def main(args: Args) -> None:
    table = sweep(args)
    label = LABELS[args.factor]
    print(f"success on --grid {args.grid}, seeds {', '.join(map(str, args.seeds))} (95 % Wilson interval)")
    print("| policy | " + " | ".join(f"{label} {v:g}" for v in args.values) + " |")
    print("|---|" + "---:|" * len(args.values))
    for name, row in table.items():
        cells = []
        for v in args.values:
            k, n = row[v]
            lo, hi = wilson_interval(k, n)
            cells.append(f"{100 * k / n:.1f} % [{100 * lo:.0f}, {100 * hi:.0f}]")
        print(f"| `{name}` | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(tyro.cli(Args))
