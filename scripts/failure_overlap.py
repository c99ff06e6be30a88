"""Do different policies fail on the same falls? The same as ``selfright compare``
(``selfright.evaluate.compare``), kept under this name for the commands in docs/training.md.

    python scripts/failure_overlap.py results/A_s4 results/A_s5 results/B_s4 results/B_s5

Reads ``selfright evaluate`` results folders (several policies, each on the same grid and
seeds; nothing is simulated), matches episodes by (seed, cell, episode) and prints each
policy's success, how many episodes each number of policies failed, the share that at least
one policy got up from, and with exactly two policies the paired McNemar test.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import tyro

from selfright.evaluate.compare import mcnemar_p, read_outcomes, report

__all__ = ["mcnemar_p"]


@dataclass(frozen=True)
class Args:
    folders: tyro.conf.Positional[tuple[Path, ...]]
    """Results folders of ``selfright evaluate`` (several policies, the same seeds)."""


def main(a: Args) -> None:
    try:
        print(report(read_outcomes(a.folders)))
    except ValueError as e:
        raise SystemExit(f"failure_overlap: {e}") from None


if __name__ == "__main__":
    main(tyro.cli(Args))
