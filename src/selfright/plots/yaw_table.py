"""The yaw study drawn like the seed's Table II: inclines as rows, down-, up- and cross-slope
headings as columns. Reads only ``yaw.csv`` and ``run.json`` of a ``selfright yaw-study`` folder."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from selfright.evaluate.claims import SEED_TABLE_II  # noqa: E402
from selfright.evaluate.yaw_results import DIRECTIONS, read_yaw_table  # noqa: E402

COLUMN_TITLES = {"down": "Down-slope", "up": "Up-slope", "cross": "Cross-slope"}
"""Table II's column headings."""


def seed_mark(slope_deg: float, direction: str) -> str:
    """The seed's Table II entry: ✓, blank (tried, no recovery) or – (not in the table)."""
    row = SEED_TABLE_II.get(float(slope_deg))
    return "–" if row is None else "✓" if row[direction] else ""


def plot_yaw(folder: str | Path) -> Path:
    """Write ``folder/yaw.png`` from ``folder/yaw.csv``: each cell coloured by the recovery rate
    under the seed's hardware rule, annotated with it, the benchmark's success rate, the
    episodes and the seed's own mark."""
    folder = Path(folder)
    path = folder / "yaw.csv"
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found; run selfright yaw-study to produce it first")
    rows = read_yaw_table(path)
    run = json.loads((folder / "run.json").read_text()) if (folder / "run.json").is_file() else {}
    slopes = sorted({float(r["slope_deg"]) for r in rows})
    by = {(float(r["slope_deg"]), r["direction"]): r for r in rows}
    values = np.array([[100 * float(by[(s, d)]["hardware_success_rate"]) for d in DIRECTIONS] for s in slopes])
    fig, ax = plt.subplots(figsize=(7.2, 1.3 + 0.9 * len(slopes)), layout="constrained")
    im = ax.imshow(values, cmap="viridis", vmin=0, vmax=100, aspect="auto")
    for i, s in enumerate(slopes):
        for j, d in enumerate(DIRECTIONS):
            r = by[(s, d)]
            mark = seed_mark(s, d)
            text = (f"{values[i, j]:.0f} %\nsuccess {100 * float(r['success_rate']):.0f} %, n={int(r['episodes'])}"
                    + (f"\nseed: {mark or '✗'}" if mark != "–" else ""))
            ax.text(j, i, text, ha="center", va="center", fontsize=8, color="white" if values[i, j] < 55 else "black")
    ax.set_xticks(range(len(DIRECTIONS)), [COLUMN_TITLES[d] for d in DIRECTIONS])
    ax.set_yticks(range(len(slopes)), [f"{s:g}°" for s in slopes])
    ax.set_ylabel("incline")
    ax.xaxis.tick_top()
    policy = run.get("policy", "?")
    ax.set_title(f"Yaw study (seed Table II), {policy}: recovered within one roll, on the incline (%)", fontsize=9)
    fig.colorbar(im, ax=ax, label="hardware-rule recoveries (%)")
    out = folder / "yaw.png"
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out
