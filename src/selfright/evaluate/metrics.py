"""Aggregate statistics of evaluation episodes (pure functions over result rows)."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

Z95 = 1.959963984540054


def wilson_interval(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (default 95 %); (0, 1) when n = 0."""
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def _mean(values: Iterable[float]) -> float | None:
    vals = list(values)
    return sum(vals) / len(vals) if vals else None


def summarize(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Success rate with Wilson 95 % CI, mean TTR/DTR over successes, mean energy, divergences.

    ``rows`` are parsed episode rows (``success`` bool, ``ttr_s``/``dtr_m`` float or None).
    """
    n = len(rows)
    wins = [r for r in rows if r["success"]]
    lo, hi = wilson_interval(len(wins), n)
    return {
        "n": n,
        "successes": len(wins),
        "success_rate": len(wins) / n if n else 0.0,
        "success_ci95": [lo, hi],
        "ttr_mean_s": _mean(r["ttr_s"] for r in wins),
        "dtr_mean_m": _mean(r["dtr_m"] for r in wins),
        "energy_mean_j": _mean(r["energy_j"] for r in rows),
        "diverged": sum(1 for r in rows if r["diverged"]),
    }
