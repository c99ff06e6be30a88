"""Which member policy π_SR should hand each grid cell to, measured: reads the results folders
of π_FLAT, π_ROUGH and π_INCLINE evaluated alone on the same grid and seed (``selfright evaluate
--policy flat|rough|incline --grid paper --seed S``), and scores multiplexer rules of the form

    incline  if slope ≥ T degrees and roughness level < R
    rough    else if roughness level ≥ 1
    flat     otherwise

by the success each would have had (every cell's rate taken from the member it picks), next to
the per-cell oracle. Nothing is simulated; the falls are the same for every member. Choose a
rule on one seed and check it on another.

    python scripts/multiplexer_rule.py --flat results/paper_s1/flat --rough results/paper_s1/rough --incline results/paper_s1/incline
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import tyro

from selfright.terrain.grid import INCLINE_ROUGHNESS_BELOW, INCLINE_SWITCH_DEG, sr_context


@dataclass(frozen=True)
class Args:
    flat: Path
    """Results folder of π_FLAT on the grid."""
    rough: Path
    """Results folder of π_ROUGH on the same grid and seed."""
    incline: Path
    """Results folder of π_INCLINE on the same grid and seed."""
    thresholds_deg: tuple[float, ...] = (10.0, 12.5, 15.0, 17.5, 20.0, 25.0)
    """Slope thresholds T to score."""
    show: int = 8
    """How many of the best rules to print."""


def cell_rates(folders: dict[str, Path]) -> dict[tuple[int, int], dict[str, object]]:
    """{(slope level, roughness level): {"slope_deg", "n", member: successes}} of every cell all members ran."""
    out: dict[tuple[int, int], dict[str, object]] = {}
    for member, folder in folders.items():
        for c in json.loads((folder / "summary.json").read_text())["cells"]:
            key = (int(c["slope_level"]), int(c["roughness_level"]))
            cell = out.setdefault(key, {"slope_deg": float(c["slope_deg"]), "n": int(c["n"])})
            if int(c["n"]) != cell["n"]:
                raise ValueError(f"cell {key} has {c['n']} episodes in {folder}, {cell['n']} elsewhere")
            cell[member] = int(c["successes"])
    return {k: v for k, v in out.items() if all(m in v for m in folders)}


def score(cells: dict[tuple[int, int], dict[str, object]], threshold_deg: float, incline_below: int) -> int:
    """Falls got up from if π_SR handed each cell to the member ``sr_context`` picks with these thresholds."""
    return sum(int(c[sr_context(float(c["slope_deg"]), k[1], threshold_deg, incline_below)]) for k, c in cells.items())


def main(args: Args) -> None:
    cells = cell_rates({"flat": args.flat, "rough": args.rough, "incline": args.incline})
    total = sum(int(c["n"]) for c in cells.values())
    levels = sorted({k[1] for k in cells})
    scored = []
    for t in args.thresholds_deg:
        for r in [*levels[1:], levels[-1] + 1]:
            scored.append((score(cells, t, r), t, r))
    oracle = sum(max(int(c[m]) for m in ("flat", "rough", "incline")) for c in cells.values())
    print(f"{len(cells)} cells, {total} falls")
    for member in ("flat", "rough", "incline"):
        print(f"  {member} everywhere: {100 * sum(int(c[member]) for c in cells.values()) / total:.1f} %")
    earlier = score(cells, INCLINE_SWITCH_DEG, levels[-1] + 1)
    print(f"  the rule until 2026-12-06 (T = {INCLINE_SWITCH_DEG:g}°, incline at every roughness): {100 * earlier / total:.1f} %")
    shipped = score(cells, INCLINE_SWITCH_DEG, INCLINE_ROUGHNESS_BELOW)
    print(f"  the shipped rule (T = {INCLINE_SWITCH_DEG:g}°, R = {INCLINE_ROUGHNESS_BELOW}): {100 * shipped / total:.1f} %")
    print(f"  per-cell oracle: {100 * oracle / total:.1f} %")
    print("best rules (incline if slope ≥ T and roughness level < R):")
    for ok, t, r in sorted(scored, key=lambda s: (-s[0], s[1], s[2]))[: args.show]:
        print(f"  T = {t:g}°, R = {r}: {100 * ok / total:.1f} %")


if __name__ == "__main__":
    main(tyro.cli(Args))
