"""Do different policies fail on the same falls? Reads ``selfright evaluate`` results folders
(several policies, each on the same grid and seeds; nothing is simulated), matches episodes
by (seed, cell, episode) and prints each policy's success, how many episodes each number of
policies failed, and the share that at least one policy got up from.

    python scripts/failure_overlap.py results/A_s4 results/A_s5 results/B_s4 results/B_s5

If the same falls defeat every policy, they are hard falls; if the failures scatter, each
policy's misses are its own. With exactly two policies it also prints the paired comparison:
the episodes only one of them got up from and the exact two-sided McNemar p-value, the chance
of a split at least that uneven if both policies were equally good on these falls (a
difference of a point or two between two rates of 1,280 episodes is usually noise).
"""

from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import tyro


@dataclass(frozen=True)
class Args:
    folders: tyro.conf.Positional[tuple[Path, ...]]
    """Results folders of ``selfright evaluate`` (several policies, the same seeds)."""


def outcomes(folders: tuple[Path, ...]) -> tuple[list[str], np.ndarray]:
    """Policy names and a (policies, episodes) success matrix over the episodes every policy
    ran; raises ValueError if fewer than two policies or no common episode."""
    runs: dict[str, dict[tuple, bool]] = defaultdict(dict)
    for f in folders:
        summary, rows = Path(f) / "summary.json", Path(f) / "episodes.csv"
        if not summary.exists() or not rows.exists():
            raise ValueError(f"{f} is not a finished selfright evaluate folder")
        s = json.loads(summary.read_text())
        name = f"{s['policy']} on {s['grid']}"
        with rows.open() as fh:
            for r in csv.DictReader(fh):
                key = (s["seed"], r["slope_level"], r["roughness_level"], r["episode"])
                runs[name][key] = r["success"] in ("1", "True", "true")
    if len(runs) < 2:
        raise ValueError("give the evaluations of at least two policies")
    names = sorted(runs)
    common = sorted(set.intersection(*(set(runs[n]) for n in names)))
    if not common:
        raise ValueError("the policies share no episode: evaluate them on the same grid and seeds")
    return names, np.array([[runs[n][k] for k in common] for n in names])


def mcnemar_p(only_a: int, only_b: int) -> float:
    """Exact two-sided McNemar p-value of ``only_a`` against ``only_b`` discordant episodes:
    2 · P(X ≤ min) for X ~ Binomial(only_a + only_b, 1/2), capped at 1."""
    n, k = only_a + only_b, min(only_a, only_b)
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(k + 1)) / (1 << n)  # integer division: no float overflow at large n
    return min(1.0, 2.0 * tail)


def main(a: Args) -> None:
    try:
        names, ok = outcomes(a.folders)
    except ValueError as e:
        raise SystemExit(f"failure_overlap: {e}") from None
    n = ok.shape[1]
    for name, row in zip(names, ok, strict=True):
        print(f"{row.mean():6.1%}  {name}")
    fails = (~ok).sum(0)
    print(f"\n{n} episodes, by how many of the {len(names)} policies failed them:")
    for k, count in enumerate(np.bincount(fails, minlength=len(names) + 1)):
        print(f"  {k:2d}: {count}")
    print(f"at least one policy succeeded: {ok.any(0).mean():.1%}; all failed: {(~ok).all(0).sum()} episodes")
    if len(names) == 2:
        only_a, only_b = int((ok[0] & ~ok[1]).sum()), int((ok[1] & ~ok[0]).sum())
        print(f"paired: only {names[0]} got up in {only_a}, only {names[1]} in {only_b}; "
              f"McNemar p = {mcnemar_p(only_a, only_b):.3f}")


if __name__ == "__main__":
    main(tyro.cli(Args))
