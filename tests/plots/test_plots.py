"""Plots from synthetic evaluator result files (no simulator involved)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from selfright.plots import make_plots
from selfright.plots.heatmaps import build_grid

NAMES = ["success.png", "ttr.png", "dtr.png", "ttr_hist.png", "dtr_hist.png"]
COLUMNS = ["slope_level", "roughness_level", "slope_pct", "slope_deg", "roughness_R", "friction",
           "episode", "seed", "success", "ttr_s", "dtr_m", "energy_j", "peak_ang_speed", "diverged"]


def _write_results(out: Path, layout: list[tuple[int, int, int]], n: int = 4) -> None:
    """Write summary.json / episodes.csv for cells ``(slope_level, roughness_level, successes)``."""
    rng = np.random.default_rng(0)
    cells, rows = [], []
    for slope_level, rough_level, successes in layout:
        pct = 10.0 * max(slope_level, 0) if slope_level >= 0 else 36.4
        deg = math.degrees(math.atan(pct / 100.0))
        base = {"slope_level": slope_level, "roughness_level": rough_level, "slope_pct": pct,
                "slope_deg": deg, "roughness_R": 0.01 * rough_level + 0.001, "friction": 0.8}
        ttrs = rng.uniform(0.5, 2.0, successes)
        dtrs = rng.uniform(0.0, 0.3, successes)
        for e in range(n):
            ok = e < successes
            rows.append({**base, "episode": e, "seed": e, "success": int(ok),
                         "ttr_s": f"{ttrs[e]:.4f}" if ok else "", "dtr_m": f"{dtrs[e]:.4f}" if ok else "",
                         "energy_j": 10.0, "peak_ang_speed": 3.0, "diverged": 0})
        cells.append({**base, "n": n, "successes": successes, "success_rate": successes / n,
                      "success_ci95": [0.0, 1.0],
                      "ttr_mean_s": float(ttrs.mean()) if successes else None,
                      "dtr_mean_m": float(dtrs.mean()) if successes else None,
                      "energy_mean_j": 10.0})
    summary = {"policy": "open_loop", "grid": "test_grid", "episodes_per_cell": n, "seed": 0,
               "config": {}, "cells": cells, "overall": {"n": n * len(cells)}}
    (out / "summary.json").write_text(json.dumps(summary))
    with open(out / "episodes.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        w.writerows(rows)


def test_make_plots_2x3_grid_with_failed_cell(tmp_path: Path) -> None:
    layout = [(s, r, 0 if (s, r) == (1, 2) else 1 + s + r) for s in (0, 1) for r in (0, 1, 2)]
    _write_results(tmp_path, layout)
    paths = make_plots(tmp_path)
    assert [p.name for p in paths] == NAMES
    for p in paths:
        assert p.parent == tmp_path and p.is_file() and p.stat().st_size > 1000


def test_make_plots_zero_successes(tmp_path: Path) -> None:
    _write_results(tmp_path, [(-1, 0, 0)])
    paths = make_plots(str(tmp_path))
    assert all(p.is_file() and p.stat().st_size > 1000 for p in paths)


def test_build_grid_orders_rows_and_columns() -> None:
    cells = [{"slope_level": sl, "roughness_level": rl, "slope_pct": pct, "slope_deg": deg,
              "roughness_R": r, "success_rate": 0.5}
             for sl, rl, pct, deg, r in [(2, 1, 20.0, 11.3, 0.02), (-1, 0, 36.4, 20.0, 0.0),
                                         (0, 1, 0.0, 0.0, 0.04), (0, 0, 0.0, 0.0, 0.0)]]
    grid = build_grid(cells)
    assert grid.row_labels == ["L0: 0% (0.0°)", "L2: 20% (11.3°)", "20.0°"]
    assert grid.col_labels == ["L0\nR=0", "L1\nR=0.03"]
    vals = grid.values("success_rate", 100.0)
    assert vals.shape == (3, 2)
    assert np.isnan(vals[1, 0]) and vals[0, 0] == 50.0
