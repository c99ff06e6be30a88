"""Policies compared on the same falls.

Every episode of ``selfright evaluate`` is a pure function of (run seed, cell, episode index),
so two policies evaluated with the same grid and seeds meet exactly the same falls. Comparing
them episode by episode (a paired test) is far more sensitive than comparing two rates: only
the falls where one policy gets up and the other does not say anything about which is better.
This module reads finished results folders (nothing is simulated), matches their episodes and
reports each policy's rate with its 95 % Wilson interval, how many policies failed each fall,
and, for two policies, the exact two-sided McNemar test on the discordant falls.
"""

from __future__ import annotations

import csv
import json
import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from selfright.evaluate.metrics import wilson_interval
from selfright.evaluate.results import with_added_defaults

Key = tuple[int, int, int, int]
"""(run seed, slope level, roughness level, episode): one fall."""


@dataclass(frozen=True)
class Outcomes:
    """Success of each policy on the falls every policy ran."""

    names: list[str]
    """One per policy: ``POLICY on GRID`` as its folders' ``summary.json`` name them."""
    keys: list[Key]
    """The shared falls, sorted."""
    ok: np.ndarray
    """(policies, falls) bool."""
    config_differs: list[str]
    """Top-level configuration sections (``summary.json`` ``config``) that differ between the
    folders: motor model, friction, ... (the falls are the same, the conditions are not)."""


def read_outcomes(folders: list[Path] | tuple[Path, ...]) -> Outcomes:
    """Group ``folders`` by policy and match their episodes. Raises ``ValueError`` for a
    folder that is not a finished evaluation, fewer than two policies, or no shared fall."""
    runs: dict[str, dict[Key, bool]] = defaultdict(dict)
    configs: list[dict] = []
    for f in folders:
        summary, rows = Path(f) / "summary.json", Path(f) / "episodes.csv"
        if not summary.exists() or not rows.exists():
            raise ValueError(f"{f} is not a finished selfright evaluate folder (no summary.json / episodes.csv)")
        s = json.loads(summary.read_text())
        configs.append(with_added_defaults(s.get("config", {})))
        name = f"{s['policy']} on {s['grid']}"
        with rows.open() as fh:
            for r in csv.DictReader(fh):
                key = (int(s["seed"]), int(r["slope_level"]), int(r["roughness_level"]), int(r["episode"]))
                runs[name][key] = r["success"] in ("1", "True", "true")
    if len(runs) < 2:
        raise ValueError("give the evaluations of at least two policies")
    names = sorted(runs)
    common = sorted(set.intersection(*(set(runs[n]) for n in names)))
    if not common:
        raise ValueError("the policies share no episode: evaluate them on the same grid and seeds")
    ok = np.array([[runs[n][k] for k in common] for n in names], dtype=bool)
    sections = sorted({k for c in configs for k in c})
    differs = [k for k in sections if any(c.get(k) != configs[0].get(k) for c in configs)]
    return Outcomes(names, common, ok, differs)


def mcnemar_p(only_a: int, only_b: int) -> float:
    """Exact two-sided McNemar p-value of ``only_a`` against ``only_b`` discordant episodes:
    2 · P(X ≤ min) for X ~ Binomial(only_a + only_b, 1/2), capped at 1."""
    n, k = only_a + only_b, min(only_a, only_b)
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(k + 1)) / (1 << n)  # exact integers: no float overflow at large n
    return min(1.0, 2.0 * tail)


def _rate(ok: np.ndarray) -> str:
    lo, hi = wilson_interval(int(ok.sum()), len(ok))
    return f"{ok.mean():6.1%} [{lo:.0%}, {hi:.0%}]"


def report(o: Outcomes, by_cell: bool = False) -> str:
    """The comparison as text (see the module docstring)."""
    n = o.ok.shape[1]
    seeds = sorted({k[0] for k in o.keys})
    lines = [f"{n} shared falls (seeds {', '.join(map(str, seeds))})"]
    if o.config_differs:
        lines.append(f"note: the folders' configurations differ in {', '.join(o.config_differs)}")
    lines += [f"{_rate(row)}  {name}" for name, row in zip(o.names, o.ok, strict=True)]
    if by_cell:
        cells = sorted({k[1:3] for k in o.keys})
        lines.append("by cell (slope level, roughness level): " + " | ".join(o.names))
        for c in cells:
            cols = np.array([k[1:3] == c for k in o.keys])
            rates = "  ".join(f"{row[cols].mean():6.1%}" for row in o.ok)
            lines.append(f"  ({c[0]:2d}, {c[1]:2d}) n={int(cols.sum()):4d}  {rates}")
    fails = (~o.ok).sum(0)
    lines.append(f"falls by how many of the {len(o.names)} policies failed them:")
    lines += [f"  {k:2d}: {count}" for k, count in enumerate(np.bincount(fails, minlength=len(o.names) + 1))]
    lines.append(f"at least one policy succeeded: {o.ok.any(0).mean():.1%}; all failed: {int((~o.ok).all(0).sum())} episodes")
    if len(o.names) == 2:
        only_a, only_b = int((o.ok[0] & ~o.ok[1]).sum()), int((o.ok[1] & ~o.ok[0]).sum())
        lines.append(f"paired: only {o.names[0]} got up in {only_a}, only {o.names[1]} in {only_b}; "
                     f"McNemar p = {mcnemar_p(only_a, only_b):.3f}")
    return "\n".join(lines)
