"""Grid heatmaps and recovery histograms from evaluator result files.

Reads only ``summary.json`` and ``episodes.csv`` written by the evaluator and writes PNGs
next to them. Rows of each heatmap are slope levels (slope increases upward), columns are
roughness levels (roughness increases to the right).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Sequence
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import Normalize  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from selfright.evaluate.results import recorded_sensor_noise  # noqa: E402

TTR_BIN_S = 0.1
"""Histogram bin width for time-to-recover, in seconds."""
DTR_BIN_M = 0.02
"""Histogram bin width for distance-to-recover, in metres."""
MISSING_COLOR = "#bdbdbd"
"""Face colour of cells with no value (no success, or cell absent from a partial grid)."""


@dataclass(frozen=True, kw_only=True)
class CellGrid:
    """Cells of ``summary.json`` laid out on a (slope × roughness) grid."""

    row_labels: list[str]
    """Tick label per row, bottom (lowest slope) first."""
    col_labels: list[str]
    """Tick label per column, left (lowest roughness) first."""
    cells: list[list[dict[str, Any] | None]]
    """``cells[row][col]``: the summary cell dict, or None where the grid has no such cell."""

    def values(self, key: str, scale: float = 1.0) -> np.ndarray:
        """Array ``(n_rows, n_cols)`` of ``cell[key] * scale``; NaN where missing or null."""
        out = np.full((len(self.row_labels), len(self.col_labels)), np.nan)
        for i, row in enumerate(self.cells):
            for j, cell in enumerate(row):
                v = None if cell is None else cell.get(key)
                if v is not None and math.isfinite(float(v)):
                    out[i, j] = float(v) * scale
        return out


def _row_label(slope_level: int, slope_pct: float, slope_deg: float) -> str:
    """Row tick label: grade and angle, or just the angle for an off-grid (-1) cell."""
    if slope_level < 0:
        return f"{slope_deg:.1f}°"
    return f"L{slope_level}: {slope_pct:.0f}% ({slope_deg:.1f}°)"


def build_grid(cells: list[dict[str, Any]]) -> CellGrid:
    """Arrange summary cells by slope (rows, by degrees) and roughness level (columns)."""
    row_keys = sorted({(float(c["slope_deg"]), int(c["slope_level"])) for c in cells})
    col_keys = sorted({int(c["roughness_level"]) for c in cells})
    row_index = {k: i for i, k in enumerate(row_keys)}
    col_index = {k: j for j, k in enumerate(col_keys)}
    grid: list[list[dict[str, Any] | None]] = [[None] * len(col_keys) for _ in row_keys]
    row_labels = [""] * len(row_keys)
    for c in cells:
        i = row_index[(float(c["slope_deg"]), int(c["slope_level"]))]
        grid[i][col_index[int(c["roughness_level"])]] = c
        row_labels[i] = _row_label(int(c["slope_level"]), float(c["slope_pct"]), float(c["slope_deg"]))
    col_labels = []
    for level in col_keys:
        rs = [float(c["roughness_R"]) for c in cells
              if int(c["roughness_level"]) == level and c.get("roughness_R") is not None]
        rs = [r for r in rs if math.isfinite(r)]
        col_labels.append(f"L{level}\nR={_fmt_r(float(np.mean(rs)))}" if rs else f"L{level}")
    return CellGrid(row_labels=row_labels, col_labels=col_labels, cells=grid)


def text_color(rgba: tuple[float, ...]) -> str:
    """Black or white, whichever reads better on a cell of colour ``rgba``."""
    r, g, b = rgba[:3]
    return "black" if 0.299 * r + 0.587 * g + 0.114 * b > 0.5 else "white"


BOX_COLOR = "#7fdc7f"
"""Edge colour of the training-context boxes (the seed's light green)."""


def heatmap(grid: CellGrid, values: np.ndarray, *, title: str, cbar_label: str, fmt: str,
            cmap_name: str, path: Path, vmin: float | None = None, vmax: float | None = None,
            na_text: str = "N/A", marks: np.ndarray | None = None,
            boxes: Sequence[tuple[str, int, int, int]] = (), compact: bool = False) -> Path:
    """Draw an annotated heatmap of ``values`` ``(n_rows, n_cols)``; NaN cells are grey.

    ``na_text`` annotates NaN cells that exist in the grid; absent cells stay blank. ``marks``
    (same shape, str) is appended to each finite cell's number. Each of ``boxes``
    ``(context name, row, first col, last col)`` is outlined in ``BOX_COLOR`` and labelled
    ``c_NAME``. ``compact`` draws smaller cells and type (for a page of many figures).
    """
    n_rows, n_cols = values.shape
    finite = values[np.isfinite(values)]
    lo = vmin if vmin is not None else (float(finite.min()) if finite.size else 0.0)
    hi = vmax if vmax is not None else (float(finite.max()) if finite.size else 1.0)
    if hi <= lo:
        hi = lo + 1.0
    norm = Normalize(vmin=lo, vmax=hi)
    cmap = plt.get_cmap(cmap_name).with_extremes(bad=MISSING_COLOR)

    (cell_w, cell_h), text_size = ((0.75, 0.5), 7) if compact else ((1.3, 0.75), 10)
    fig, ax = plt.subplots(figsize=(1.6 + cell_w * n_cols, 1.4 + cell_h * n_rows), layout="constrained")
    im = ax.imshow(np.ma.masked_invalid(values), cmap=cmap, norm=norm, origin="lower", aspect="auto")
    for i in range(n_rows):
        for j in range(n_cols):
            v = values[i, j]
            if np.isfinite(v):
                ax.text(j, i, format(v, fmt) + ("" if marks is None else marks[i, j]), ha="center", va="center",
                        fontsize=text_size, color=text_color(cmap(norm(v))))
            elif grid.cells[i][j] is not None:
                ax.text(j, i, na_text, ha="center", va="center", fontsize=text_size, color="black")
    for name, row, c0, c1 in boxes:
        ax.add_patch(Rectangle((c0 - 0.5, row - 0.5), c1 - c0 + 1, 1, fill=False, edgecolor=BOX_COLOR, linewidth=2.5))
        ax.text(c0 - 0.45, row + 0.45, f"c_{name.upper()}", ha="left", va="top", fontsize=text_size - 1,
                color=BOX_COLOR, fontweight="bold")
    tick_size = {"fontsize": text_size - 1} if compact else {}
    ax.set_xticks(range(n_cols), grid.col_labels, **tick_size)
    ax.set_yticks(range(n_rows), grid.row_labels, **tick_size)
    ax.set_xlabel("roughness level")
    ax.set_ylabel("slope grade (angle)")
    ax.set_title(title, fontsize=text_size + 2 if compact else 10)
    fig.colorbar(im, ax=ax, label=cbar_label)
    fig.savefig(path, dpi=110 if compact else 120)
    plt.close(fig)
    return path


def read_successful(episodes_csv: Path, column: str) -> np.ndarray:
    """Values of ``column`` over successful episodes in ``episodes.csv``, shape ``(n_success,)``."""
    vals: list[float] = []
    with open(episodes_csv, newline="") as f:
        for row in csv.DictReader(f):
            raw = (row.get(column) or "").strip()
            if int(float(row.get("success") or 0)) == 1 and raw:
                v = float(raw)
                if math.isfinite(v):
                    vals.append(v)
    return np.asarray(vals, dtype=float)


def histogram(values: np.ndarray, *, bin_width: float, title: str, xlabel: str, path: Path) -> Path:
    """Histogram of ``values`` with bins of ``bin_width`` aligned to multiples of it."""
    fig, ax = plt.subplots(figsize=(6.0, 3.8), layout="constrained")
    if values.size == 0:
        ax.text(0.5, 0.5, "no successful episodes", ha="center", va="center",
                transform=ax.transAxes, fontsize=12, color="dimgray")
        ax.set_xticks([])
        ax.set_yticks([])
    else:
        start = math.floor(values.min() / bin_width) * bin_width
        n_bins = math.floor((values.max() - start) / bin_width) + 1
        edges = start + bin_width * np.arange(n_bins + 1)
        ax.hist(values, bins=edges, color=plt.get_cmap("viridis")(0.35), edgecolor="white")
        ax.axvline(float(values.mean()), color="black", linestyle="--", linewidth=1,
                   label=f"mean {values.mean():.3g} (n={values.size})")
        ax.legend(loc="upper right", fontsize=9)
        ax.set_ylabel("episodes")
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(xlabel)
    ax.set_title(title, fontsize=10)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def make_plots(out_dir: str | Path) -> list[Path]:
    """Write success / TTR / DTR heatmaps and TTR / DTR histograms into ``out_dir``.

    Reads ``out_dir/summary.json`` and ``out_dir/episodes.csv``. Returns the PNG paths in the
    order success.png, ttr.png, dtr.png, ttr_hist.png, dtr_hist.png.
    """
    out = Path(out_dir)
    summary_path, episodes_path = out / "summary.json", out / "episodes.csv"
    for p in (summary_path, episodes_path):
        if not p.is_file():
            raise FileNotFoundError(f"{p} not found; run the evaluator to produce it first")
    summary = json.loads(summary_path.read_text())
    cells = summary.get("cells") or []
    if not cells:
        raise ValueError(f"{summary_path} has no cells; nothing to plot")
    tag = f"{summary.get('policy', '?')} on {summary.get('grid', '?')}"
    noise = recorded_sensor_noise(summary)
    tag += f", sensor noise ×{noise:g}" if noise > 0 else ""
    n_ep = summary.get("episodes_per_cell")
    per_cell = f", {n_ep} episodes/cell" if n_ep else ""
    grid = build_grid(cells)

    paths = [
        heatmap(grid, grid.values("success_rate", 100.0), path=out / "success.png",
                 title=f"Success rate (%) across slope and roughness\n{tag}{per_cell}",
                 cbar_label="success rate (%)", fmt=".0f", cmap_name="viridis",
                 vmin=0.0, vmax=100.0),
        heatmap(grid, grid.values("ttr_mean_s"), path=out / "ttr.png",
                 title=f"Mean time to recover (s), successful episodes\n{tag}",
                 cbar_label="time to recover (s)", fmt=".2f", cmap_name="magma_r"),
        heatmap(grid, grid.values("dtr_mean_m"), path=out / "dtr.png",
                 title=f"Mean distance to recover (m), successful episodes\n{tag}",
                 cbar_label="distance to recover (m)", fmt=".3f", cmap_name="magma_r"),
        histogram(read_successful(episodes_path, "ttr_s"), bin_width=TTR_BIN_S,
                   path=out / "ttr_hist.png", xlabel="time to recover (s)",
                   title=f"Time to recover, all successful episodes\n{tag}"),
        histogram(read_successful(episodes_path, "dtr_m"), bin_width=DTR_BIN_M,
                   path=out / "dtr_hist.png", xlabel="distance to recover (m)",
                   title=f"Distance to recover, all successful episodes\n{tag}"),
    ]
    return paths


def success_difference(folders: list[Path] | tuple[Path, ...]) -> tuple[CellGrid, np.ndarray, np.ndarray, Any]:
    """(grid, difference, marks, outcomes) of two policies' results folders: per cell, the second
    policy's success (name order, as ``selfright compare`` groups them) minus the first's in points
    on the falls both ran, and ``"*"`` where the exact McNemar test there gives p < 0.05."""
    from selfright.evaluate.compare import mcnemar_p, read_outcomes

    o = read_outcomes(folders)
    if len(o.names) != 2:
        raise ValueError(f"a difference heatmap needs exactly two policies, got {len(o.names)}: {', '.join(o.names)}")
    cells: dict[tuple[int, int], dict[str, Any]] = {}
    for f in folders:
        for c in json.loads((Path(f) / "summary.json").read_text()).get("cells") or []:
            cells.setdefault((int(c["slope_level"]), int(c["roughness_level"])), c)
    if not cells:
        raise ValueError("the folders' summary.json list no cells")
    grid = build_grid(list(cells.values()))
    keys = np.array([k[1:3] for k in o.keys])
    a, b = o.ok
    diff = np.full((len(grid.row_labels), len(grid.col_labels)), np.nan)
    marks = np.full(diff.shape, "", dtype=object)
    for i, row in enumerate(grid.cells):
        for j, cell in enumerate(row):
            here = None if cell is None else (
                (keys[:, 0] == int(cell["slope_level"])) & (keys[:, 1] == int(cell["roughness_level"])))
            if here is not None and here.any():
                diff[i, j] = 100.0 * (b[here].mean() - a[here].mean())
                marks[i, j] = "*" if mcnemar_p(int((a & ~b)[here].sum()), int((b & ~a)[here].sum())) < 0.05 else ""
    return grid, diff, marks, o


def difference_heatmap(folders: list[Path] | tuple[Path, ...], path: str | Path) -> Path:
    """``success_difference`` drawn (red: the first policy better, blue: the second) to ``path``.
    Reads only the folders' result files."""
    from selfright.evaluate.compare import mcnemar_p

    grid, diff, marks, o = success_difference(folders)
    a, b = o.ok
    span = max(10.0, float(np.nanmax(np.abs(diff))) if np.isfinite(diff).any() else 10.0)
    p_all = mcnemar_p(int((a & ~b).sum()), int((b & ~a).sum()))
    title = (f"Success, {o.names[1]} minus {o.names[0]} (points), {len(o.keys)} shared falls\n"
             f"overall {100.0 * (b.mean() - a.mean()):+.1f} points, McNemar p = {p_all:.3g}; * p < 0.05 in the cell")
    return heatmap(grid, diff, title=title, cbar_label="success difference (points)", fmt="+.0f",
                    cmap_name="RdBu", path=Path(path), vmin=-span, vmax=span, marks=marks)


def _fmt_r(r: float) -> str:
    """Roughness label; float round-off of a perfect plane (~1e-13) shows as 0."""
    return "0" if abs(r) < 1e-9 else f"{r:.3g}"
