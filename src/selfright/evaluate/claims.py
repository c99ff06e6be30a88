"""The seed's claims about its results, each checked on our result files.

Every claim is a small pure function of parsed result data (a ``summary.json`` dict, or the rows
of a ``yaw.csv``) returning a ``Verdict``: our numbers in words and whether they bear the claim
out. Thresholds are stated in each function; ``n/a`` when the results lack the cells it needs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

SEED_TABLE_II: dict[float, dict[str, bool]] = {
    12.0: {"down": True, "up": True, "cross": True},
    15.0: {"down": False, "up": True, "cross": True},
    18.0: {"down": False, "up": False, "cross": True},
}
"""The seed's Table II (§VI-B): successful recovery (✓) of its baseline controller on the
Unitree A1 by incline (deg) and initial heading (down-, up-, cross-slope)."""

GOOD_RATE = 0.5
"""A success rate at least this is "does well" / "good success" in the claims below."""
MARGIN = 0.1
"""A difference of at least this (10 points) is "better" / "degrades" in the claims below."""


@dataclass(frozen=True)
class Verdict:
    """Our side of one claim."""

    ours: str
    """Our numbers, in words."""
    verdict: str
    """``supported``, ``not supported`` or ``n/a``."""


def _rate(cells: list[dict[str, Any]]) -> float | None:
    """Pooled success rate of summary cells (successes / episodes); None if there are none."""
    n = sum(int(c["n"]) for c in cells)
    return sum(int(c["successes"]) for c in cells) / n if n else None


def _pct(v: float | None) -> str:
    return "–" if v is None else f"{100 * v:.0f} %"


def _cells(summary: dict[str, Any], keep: Callable[[dict[str, Any]], bool]) -> list[dict[str, Any]]:
    return [c for c in summary.get("cells") or [] if int(c["slope_level"]) >= 0 and keep(c)]


def _verdict(ok: bool | None) -> str:
    return "n/a" if ok is None else "supported" if ok else "not supported"


def flat_good_until(summary: dict[str, Any], slope_level: int = 5, roughness_level: int = 10) -> Verdict:
    """"π_FLAT does quite well until slope level 5 and roughness level 10; after this,
    performance starts to degrade on both axes": the cells up to both levels pooled reach
    ``GOOD_RATE`` and beat the cells beyond either level by ``MARGIN``."""
    inside = _rate(_cells(summary, lambda c: c["slope_level"] <= slope_level and c["roughness_level"] <= roughness_level))
    beyond = _rate(_cells(summary, lambda c: c["slope_level"] > slope_level or c["roughness_level"] > roughness_level))
    ok = None if inside is None or beyond is None else inside >= GOOD_RATE and inside - beyond >= MARGIN
    return Verdict(f"{_pct(inside)} up to slope level {slope_level} and roughness level {roughness_level}, {_pct(beyond)} beyond", _verdict(ok))


def rough_better_on_rough(rough: dict[str, Any], flat: dict[str, Any]) -> Verdict:
    """"π_ROUGH does much better on all rough terrain": over the cells of roughness level ≥ 1
    both ran, π_ROUGH's pooled rate beats π_FLAT's by ``MARGIN``."""
    keys = {(c["slope_level"], c["roughness_level"]) for c in _cells(flat, lambda c: c["roughness_level"] >= 1)}
    r = _rate(_cells(rough, lambda c: (c["slope_level"], c["roughness_level"]) in keys))
    f = _rate(_cells(flat, lambda c: (c["slope_level"], c["roughness_level"]) in keys))
    ok = None if r is None or f is None else r - f >= MARGIN
    return Verdict(f"π_ROUGH {_pct(r)} against π_FLAT {_pct(f)} on rough cells", _verdict(ok))


def rough_struggles_on_steep(rough: dict[str, Any], slope_level: int = 5) -> Verdict:
    """"π_ROUGH ... similarly struggles to adapt at higher terrain slopes": its rate on slope
    levels above ``slope_level`` is at least ``MARGIN`` below its rate up to it."""
    low = _rate(_cells(rough, lambda c: c["slope_level"] <= slope_level))
    high = _rate(_cells(rough, lambda c: c["slope_level"] > slope_level))
    ok = None if low is None or high is None else low - high >= MARGIN
    return Verdict(f"{_pct(low)} up to slope level {slope_level}, {_pct(high)} above", _verdict(ok))


def incline_good_on_gentler(incline: dict[str, Any], training_deg: float = 20.0) -> Verdict:
    """"π_INCLINE exhibits good success on slopes gentler than the training set": on smooth
    cells (roughness level 0) gentler than ``training_deg`` it reaches ``GOOD_RATE``; its rate on
    steeper smooth cells is reported beside."""
    gentle = _rate(_cells(incline, lambda c: c["roughness_level"] == 0 and c["slope_deg"] < training_deg))
    steep = _rate(_cells(incline, lambda c: c["roughness_level"] == 0 and c["slope_deg"] >= training_deg))
    ok = None if gentle is None else gentle >= GOOD_RATE
    return Verdict(f"{_pct(gentle)} on smooth slopes below {training_deg:g}°, {_pct(steep)} at or above", _verdict(ok))


def _yaw_rate(rows: list[dict[str, Any]], direction: str, keep: Callable[[float], bool] = lambda d: True) -> float | None:
    here = [r for r in rows if r["direction"] == direction and keep(float(r["slope_deg"]))]
    n = sum(int(r["episodes"]) for r in here)
    return sum(int(r["hardware_successes"]) for r in here) / n if n else None


def cross_most_likely(rows: list[dict[str, Any]]) -> Verdict:
    """"Cross-slope is the most likely to succeed": pooled over the study's slopes, the
    cross-slope heading's rate (the seed's hardware rule) is at least the down- and up-slope ones."""
    r = {d: _yaw_rate(rows, d) for d in ("down", "up", "cross")}
    ok = None if None in r.values() else r["cross"] >= max(r["down"], r["up"])
    return Verdict(", ".join(f"{d} {_pct(v)}" for d, v in r.items()), _verdict(ok))


def up_helps_on_steeper(rows: list[dict[str, Any]]) -> Verdict:
    """"The up-slope rolling behavior imparts a boost in performance on steeper slopes": on the
    slopes above the study's gentlest, the up-slope heading's rate (hardware rule) beats the
    down-slope one's."""
    slopes = sorted({float(r["slope_deg"]) for r in rows})
    if len(slopes) < 2:
        return Verdict("needs two slopes or more", "n/a")
    steep = lambda d: d > slopes[0]  # noqa: E731
    up, down = _yaw_rate(rows, "up", steep), _yaw_rate(rows, "down", steep)
    ok = None if up is None or down is None else up > down
    return Verdict(f"above {slopes[0]:g}°: up {_pct(up)}, down {_pct(down)}", _verdict(ok))
