"""What does the reward pay for as training goes on? Reads a run's tensorboard files and
prints, per window of iterations, the mean per-episode sum of every weighted reward term
(``Episode_Reward/<term>``, already × weight × dt) next to the fraction of env steps in the
goal set (``Metrics/in_goal``): the terms that grow while ``in_goal`` falls are what the
policy trades the goal set for.

    python scripts/reward_terms.py --run runs/incline_teacher --windows 100 230 400 600 800 1000
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import tyro

TAGS = ("Episode_Reward/", "Metrics/in_goal", "Metrics/upright_cos", "Metrics/refall_per_s", "Episode/success_rate",
        "Episode/left_tile_rate")


@dataclass(frozen=True)
class Args:
    run: Path
    """Training run folder (holds ``events.out.tfevents.*``)."""
    windows: tuple[int, ...] = ()
    """Iteration bounds, pairs lo hi (lo inclusive, hi exclusive); default: thirds of the
    logged iterations."""


def read_scalars(run: Path) -> dict[str, dict[int, float]]:
    """{tag: {iteration: value}} of the tags of interest over every event file of ``run``."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    files = sorted(run.glob("events.out.tfevents.*"))
    if not files:
        raise SystemExit(f"no tensorboard event files in {run}")
    data: dict[str, dict[int, float]] = {}
    for f in files:
        acc = EventAccumulator(str(f), size_guidance={"scalars": 0})
        acc.Reload()
        for tag in acc.Tags()["scalars"]:
            if tag.startswith(TAGS):
                data.setdefault(tag, {}).update({e.step: e.value for e in acc.Scalars(tag)})
    return data


def window_means(data: dict[str, dict[int, float]], windows: list[tuple[int, int]]) -> dict[str, list[float]]:
    """Mean of each tag over each [lo, hi) window of iterations (nan where it has no value)."""
    out = {}
    for tag, series in sorted(data.items()):
        row = []
        for lo, hi in windows:
            vals = [v for it, v in series.items() if lo <= it < hi]
            row.append(sum(vals) / len(vals) if vals else float("nan"))
        out[tag] = row
    return out


def main(args: Args) -> None:
    data = read_scalars(args.run)
    if args.windows:
        if len(args.windows) % 2:
            raise SystemExit("--windows takes pairs: lo hi [lo hi ...]")
        windows = list(zip(args.windows[::2], args.windows[1::2]))
    else:
        first = min(min(s) for s in data.values())
        span = max(max(s) for s in data.values()) + 1 - first
        windows = [(first + k * span // 3, first + (k + 1) * span // 3) for k in range(3)]
    print(f"{'iterations':32s}" + "".join(f"{f'{lo}-{hi - 1}':>12s}" for lo, hi in windows))
    for tag, row in window_means(data, windows).items():
        print(f"{tag.removeprefix('Episode_Reward/'):32s}" + "".join(f"{v:12.3f}" for v in row))


if __name__ == "__main__":
    main(tyro.cli(Args))
