"""Pool evaluations of one policy over several seeds: per-seed success and the pooled rate
with its 95 % Wilson interval, read from each results folder's ``summary.json`` (nothing is
simulated). The multi-seed rates in the README and model cards are printed by this.

    python scripts/seed_table.py results/m7/flat_s0 results/m7/flat_s1 results/m7/flat_s2 results/m7/flat_s3
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import tyro

from selfright.evaluate.metrics import wilson_interval


@dataclass(frozen=True)
class Args:
    folders: tyro.conf.Positional[tuple[Path, ...]]
    """Results folders of ``selfright evaluate`` (one policy and grid, different seeds)."""


def pooled(folders: tuple[Path, ...]) -> list[tuple[str, int, int]]:
    """(label, successes, episodes) per folder, then ``("pooled", k, n)``; raises ValueError if
    the folders mix policies, grids or episode counts, or repeat a seed."""
    rows, ident, seeds = [], None, set()
    for f in folders:
        path = Path(f) / "summary.json"
        if not path.exists():
            raise ValueError(f"{path} not found; run selfright evaluate --out {f} first")
        s = json.loads(path.read_text())
        key = (s["policy"], s["grid"], s["episodes_per_cell"])
        if ident is not None and key != ident:
            raise ValueError(f"{f} is {key}, not {ident}: pool one policy on one grid")
        if s["seed"] in seeds:
            raise ValueError(f"seed {s['seed']} appears twice")
        ident = key
        seeds.add(s["seed"])
        o = s["overall"]
        rows.append((f"seed {s['seed']}", round(o["success_rate"] * o["n"]), int(o["n"])))
    k, n = sum(r[1] for r in rows), sum(r[2] for r in rows)
    return [*rows, ("pooled", k, n)]


def main(a: Args) -> None:
    if not a.folders:
        raise SystemExit("seed_table: give one or more results folders")
    try:
        rows = pooled(a.folders)
    except ValueError as e:
        raise SystemExit(f"seed_table: {e}") from None
    for label, k, n in rows:
        lo, hi = wilson_interval(k, n)
        print(f"{label:>8}: {k:4d} / {n:4d} = {100 * k / n:5.1f} %  [{100 * lo:.0f}, {100 * hi:.0f}]")


if __name__ == "__main__":
    main(tyro.cli(Args))
