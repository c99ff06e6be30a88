"""One replayed episode over time, from ``selfright replay``'s ``trace.csv`` and
``replay.json``: body height over the feet (and, for comparison, over the terrain beneath the
trunk) against the goal bar, roll and pitch against the tilt limit,
feet on the ground, with the stretches in the goal set shaded."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def read_trace(folder: Path) -> dict[str, np.ndarray]:
    """Columns of ``trace.csv`` as float arrays."""
    with open(Path(folder) / "trace.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{folder}/trace.csv has no rows")
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


def plot_trace(folder: Path) -> Path:
    """Write ``trace.png`` next to the trace; returns its path."""
    folder = Path(folder)
    tr = read_trace(folder)
    meta = json.loads((folder / "replay.json").read_text())
    t, goal = tr["t_s"], tr["in_goal"] > 0
    fig, axes = plt.subplots(3, 1, figsize=(7, 5.5), sharex=True)
    panels = [
        (axes[0], [("height_over_feet_m", "height over the feet"), ("height_over_terrain_m", "height over the terrain")],
         "m", [meta["goal_height_m"]]),
        (axes[1], [("roll_deg", "roll"), ("pitch_deg", "pitch")], "deg", [-meta["max_tilt_deg"], meta["max_tilt_deg"]]),
        (axes[2], [("feet_down", "feet on ground"), ("body_contacts", "other bodies on ground")], "count", [4]),
    ]
    for ax, series, unit, bars in panels:
        for col, label in series:
            ax.plot(t, tr[col], label=label, drawstyle="steps-post" if unit == "count" else "default")
        for b in bars:
            ax.axhline(b, color="0.4", lw=0.8, ls="--")
        ax.fill_between(t, 0, 1, where=goal, transform=ax.get_xaxis_transform(), color="tab:green", alpha=0.15, lw=0)
        ax.set_ylabel(unit)
        ax.legend(loc="upper right", fontsize=8)
    outcome = f"success, TTR {meta['ttr_s']:.2f} s" if meta["success"] else "failure"
    axes[0].set_title(
        f"{meta['policy']} · slope {meta['slope_pct']:.0f} %, roughness level {meta['roughness_level']} · "
        f"episode {meta['episode']} (seed {meta['seed']}) · {outcome}; green: in the goal set",
        fontsize=9,
    )
    axes[-1].set_xlabel("time since policy start (s)")
    fig.tight_layout()
    path = folder / "trace.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
