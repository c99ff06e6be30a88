"""The report of ``selfright report``: ``report.md`` and a self-contained ``index.html`` (PNG
figures beside it), in the seed's order: per policy the success / TTR / DTR heatmaps with the
training contexts boxed, the TTR / DTR histograms, then Table II beside our yaw study, then the
seed's claims with our numbers. Reads only result files (``report.json`` and the folders it lists).

``draw_figures`` draws the PNGs (from ``summary.json``, ``episodes.csv`` and ``yaw.csv``);
``write_report`` writes the two pages from ``report.json``, ``summary.json`` and ``yaw.csv``
alone and links a policy's raw files only where they are in the folder, so it also writes the
pages of a published copy that leaves ``episodes.csv`` out (``scripts/publish_report.py``)."""

from __future__ import annotations

import html
import json
import math
import re
from pathlib import Path
from typing import Any

from selfright.evaluate import claims
from selfright.evaluate.yaw_results import DIRECTIONS, read_yaw_table
from selfright.plots.heatmaps import DTR_BIN_M, TTR_BIN_S, CellGrid, build_grid, heatmap, histogram, read_successful
from selfright.plots.yaw_table import COLUMN_TITLES, plot_yaw, seed_mark

SEED_FIGURES = {
    ("flat", "success"): 4, ("flat", "ttr"): 5, ("flat", "dtr"): 6, ("flat", "ttr_hist"): 7, ("flat", "dtr_hist"): 8,
    ("incline", "success"): 9, ("rough", "success"): 11, ("rough", "ttr"): 12, ("rough", "dtr"): 13,
    ("rough", "ttr_hist"): 14, ("rough", "dtr_hist"): 15,
}
"""(policy, figure) → the seed's figure number showing the same thing for its policy."""
HEATMAPS = (
    ("success", "success_rate", 100.0, "Success rate (%)", "success rate (%)", ".0f", "viridis", (0.0, 100.0)),
    ("ttr", "ttr_mean_s", 1.0, "Mean time to recover (s)", "time to recover (s)", ".2f", "magma_r", (None, None)),
    ("dtr", "dtr_mean_m", 1.0, "Mean distance to recover (m)", "distance to recover (m)", ".3f", "magma_r", (None, None)),
)
"""(figure, summary key, scale, title, colour-bar label, number format, colour map, (vmin, vmax))."""
HISTOGRAMS = (
    ("ttr_hist", "ttr_s", TTR_BIN_S, "time to recover (s)"),
    ("dtr_hist", "dtr_m", DTR_BIN_M, "distance to recover (m)"),
)
"""(figure, ``episodes.csv`` column of the successful episodes, bin width, axis label)."""
RAW_FILES = ("summary.json", "episodes.csv")
"""A policy's result files the page links to, each where it is in the policy's folder."""

Block = tuple
"""One piece of the page: ("h1"|"h2"|"h3"|"p", text), ("img", src, caption), ("table", header, rows) or
("nav", section titles): links to the page's ``h2`` sections (the HTML page only)."""


def box_cells(cells: list[dict[str, Any]], box: dict[str, Any], tolerance_deg: float = 3.0) -> list[dict[str, Any]]:
    """The summary cells inside a context box (a ``ContextBox`` as a dict): on the grid row whose
    slope is nearest the box's (if within ``tolerance_deg``), with a roughness extent in the box's
    range."""
    rows = sorted({float(c["slope_deg"]) for c in cells})
    if not rows:
        return []
    nearest = min(rows, key=lambda d: abs(d - box["slope_deg"]))
    if abs(nearest - box["slope_deg"]) > tolerance_deg:
        return []
    return [c for c in cells if math.isclose(float(c["slope_deg"]), nearest)
            and box["extent_low_m"] - 1e-12 <= float(c["roughness_extent_m"]) <= box["extent_high_m"] + 1e-12]


def grid_boxes(grid: CellGrid, cells: list[dict[str, Any]], boxes: list[dict[str, Any]]) -> list[tuple[str, int, int, int]]:
    """Each context box as (name, row, first col, last col) of ``grid``; boxes with no cell are left out."""
    where = {id(c): (i, j) for i, row in enumerate(grid.cells) for j, c in enumerate(row) if c is not None}
    out = []
    for b in boxes:
        spots = [where[id(c)] for c in box_cells(cells, b)]
        if spots:
            out.append((b["context"], spots[0][0], min(j for _, j in spots), max(j for _, j in spots)))
    return out


def read_manifest(out: Path) -> dict[str, Any]:
    """The ``report.json`` in ``out`` (written by ``selfright.evaluate.report.run_report``)."""
    path = out / "report.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found; run selfright report to produce it first")
    return json.loads(path.read_text())


def _tag(name: str, summary: dict[str, Any]) -> str:
    """A policy's figure subtitle: its name, grid and episodes per cell."""
    return f"{name} on {summary['grid']}, {summary['episodes_per_cell']} episodes/cell"


def draw_policy_figures(folder: Path, name: str, boxes: list[dict[str, Any]]) -> None:
    """Draw one policy's heatmaps (from ``summary.json``, ``boxes`` its training contexts) and
    histograms (from ``episodes.csv``) into ``folder`` as ``report_FIGURE.png``."""
    summary = json.loads((folder / "summary.json").read_text())
    cells = summary["cells"]
    grid = build_grid(cells)
    drawn = grid_boxes(grid, cells, boxes)
    tag = _tag(name, summary)
    for fig, key, scale, title, label, fmt, cmap, (lo, hi) in HEATMAPS:
        heatmap(grid, grid.values(key, scale), title=f"{title}\n{tag}", cbar_label=label, fmt=fmt, cmap_name=cmap,
                vmin=lo, vmax=hi, path=folder / f"report_{fig}.png", boxes=drawn, compact=True)
    for fig, col, width, label in HISTOGRAMS:
        histogram(read_successful(folder / "episodes.csv", col), bin_width=width, xlabel=label,
                  path=folder / f"report_{fig}.png",
                  title=f"{label[0].upper()}{label[1:]}, successful episodes, bins of {width:g}\n{tag}")


def data_links(out: Path, names: list[str]) -> str:
    """``Data: [a](a), [b](b).`` for those of ``names`` (paths relative to ``out``) that are files
    in ``out``; empty when none is."""
    present = [n for n in names if (out / n).is_file()]
    return f"Data: {', '.join(f'[{n}]({n})' for n in present)}." if present else ""


def policy_blocks(folder: Path, name: str) -> list[Block]:
    """One policy's page blocks, from its ``summary.json``: overall success, links to those of its
    ``RAW_FILES`` that are in ``folder``, and its figures (image paths relative to the report,
    i.e. ``folder.name/...``)."""
    summary = json.loads((folder / "summary.json").read_text())
    tag = _tag(name, summary)
    o = summary["overall"]
    overall = f"Overall: {o['successes']} of {o['n']} episodes recovered ({100 * o['success_rate']:.1f} %)."
    links = data_links(folder.parent, [f"{folder.name}/{f}" for f in RAW_FILES])
    blocks: list[Block] = [("h2", f"Policy {name}"), ("p", f"{overall} {links}".rstrip())]
    blocks += [("img", f"{folder.name}/report_{fig}.png", _caption(name, fig, f"{title}, {tag}; training contexts boxed"))
               for fig, _, _, title, *_ in HEATMAPS]
    blocks += [("img", f"{folder.name}/report_{fig}.png", _caption(name, fig, f"{label}, bins of {width:g}"))
               for fig, _, width, label in HISTOGRAMS]
    return blocks


def _caption(policy: str, fig: str, text: str) -> str:
    n = SEED_FIGURES.get((policy, fig))
    return f"{text}" + (f" (seed Fig. {n})" if n else "")


def table_ii_blocks(out: Path, entries: list[dict[str, str]]) -> list[Block]:
    """Table II beside each policy's yaw study (hardware-rule recoveries, benchmark successes), from
    its ``yaw.csv``; the figure is ``yaw/yaw.png``."""
    blocks: list[Block] = [("h2", "Yaw study: Table II"),
                           ("p", "Recoveries within less than one full roll and without leaving the incline (the seed's "
                                 "hardware rule), from headings within ±15° of down-, up- and cross-slope "
                                 "(docs/benchmark.md, *Yaw study*). Seed: ✓ recovered on the A1, ✗ did not.")]
    for e in entries:
        yaw_csv = f"{e['folder']}/yaw/yaw.csv"
        rows = read_yaw_table(out / yaw_csv)
        by = {(float(r["slope_deg"]), r["direction"]): r for r in rows}
        slopes = sorted({s for s, _ in by})
        table = [[f"{s:g}°"] + [
            f"seed {(seed_mark(s, d) or '✗') if seed_mark(s, d) != '–' else '–'} · ours {100 * float(by[(s, d)]['hardware_success_rate']):.0f} %"
            f" (success {100 * float(by[(s, d)]['success_rate']):.0f} %, n={int(by[(s, d)]['episodes'])})"
            for d in DIRECTIONS] for s in slopes]
        blocks += [("h3", f"{e['name']}"), ("table", ["incline"] + [COLUMN_TITLES[d] for d in DIRECTIONS], table),
                   ("img", f"{e['folder']}/yaw/yaw.png", f"{e['name']}: yaw study laid out like the seed's Table II"),
                   ("p", data_links(out, [yaw_csv]))]
    return blocks


def claim_rows(out: Path, entries: list[dict[str, str]]) -> list[list[str]]:
    """[claim, policy, ours, verdict] for each of the seed's claims the report's policies allow."""
    summaries = {e["name"]: json.loads((out / e["folder"] / "summary.json").read_text()) for e in entries}
    rows: list[list[str]] = []

    def add(text: str, who: str, v: claims.Verdict) -> None:
        rows.append([text, who, v.ours, v.verdict])

    if "flat" in summaries:
        add("π_FLAT does quite well until slope level 5 and roughness level 10", "flat", claims.flat_good_until(summaries["flat"]))
    if "rough" in summaries and "flat" in summaries:
        add("π_ROUGH does much better on all rough terrain", "rough vs flat",
            claims.rough_better_on_rough(summaries["rough"], summaries["flat"]))
    if "rough" in summaries:
        add("π_ROUGH similarly struggles at higher terrain slopes", "rough", claims.rough_struggles_on_steep(summaries["rough"]))
    if "incline" in summaries:
        add("π_INCLINE exhibits good success on slopes gentler than its training slope", "incline",
            claims.incline_good_on_gentler(summaries["incline"]))
    for e in entries:
        yaw = read_yaw_table(out / e["folder"] / "yaw" / "yaw.csv")
        add("Cross-slope is the most likely to succeed (Table II)", e["name"], claims.cross_most_likely(yaw))
        add("Up-slope rolling helps on steeper slopes (Table II)", e["name"], claims.up_helps_on_steeper(yaw))
    return rows


def draw_figures(out_dir: str | Path) -> None:
    """Draw every figure of the report in ``out_dir`` (which holds the ``report.json`` of
    ``selfright.evaluate.report.run_report``): each policy's heatmaps, histograms and yaw table."""
    out = Path(out_dir)
    m = read_manifest(out)
    for e in m["policies"]:
        draw_policy_figures(out / e["folder"], e["name"], m["context_boxes"])
        plot_yaw(out / e["folder"] / "yaw")


def write_report(out_dir: str | Path) -> tuple[Path, Path]:
    """Write ``report.md`` and ``index.html`` into ``out_dir`` (which holds the ``report.json`` of
    ``selfright.evaluate.report.run_report`` and the figures of ``draw_figures``); returns both
    paths. Reads ``report.json``, each policy's ``summary.json`` and ``yaw.csv``, never ``episodes.csv``."""
    out = Path(out_dir)
    m = read_manifest(out)
    entries = m["policies"]
    blocks: list[Block] = [
        ("h1", "Self-righting benchmark report"),
        ("p", f"Benchmark version {m['benchmark_version']}, grid {m['grid']}, {m['episodes']} episodes per cell and per "
              f"yaw-study heading, seed {m['seed']}; policies: {', '.join(e['name'] for e in entries)}. Heatmap rows are "
              "slope levels (steeper upward), columns roughness levels; light green boxes mark the seed's training "
              "contexts (c_FLAT, c_ROUGH, c_INCLINE; a box appears where the grid has its cells)."),
    ]
    for e in entries:
        blocks += policy_blocks(out / e["folder"], e["name"])
    blocks += table_ii_blocks(out, entries)
    blocks += [("h2", "The seed's claims and our numbers"),
               ("p", f"Verdicts use a success rate of {100 * claims.GOOD_RATE:.0f} % for \"does well\" and a margin of "
                     f"{100 * claims.MARGIN:.0f} points for \"better\" (selfright.evaluate.claims)."),
               ("table", ["claim (seed)", "policy", "ours", "verdict"], claim_rows(out, entries))]
    blocks.insert(2, ("nav", [b[1] for b in blocks if b[0] == "h2"]))  # after the opening paragraph
    md, page = out / "report.md", out / "index.html"
    md.write_text(to_markdown(blocks))
    page.write_text(to_html(blocks))
    return md, page


def to_markdown(blocks: list[Block]) -> str:
    lines: list[str] = []
    for b in blocks:
        if b[0] in ("h1", "h2", "h3"):
            lines += ["#" * int(b[0][1]) + " " + b[1], ""]
        elif b[0] == "p":
            lines += [b[1], ""]
        elif b[0] == "img":
            lines += [f"![{b[2]}]({b[1]})", "", f"*{b[2]}*", ""]
        elif b[0] == "table":
            lines += ["| " + " | ".join(b[1]) + " |", "|" + "---|" * len(b[1])]
            lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in b[2]] + [""]
    return "\n".join(lines)


def _inline(text: str) -> str:
    """Escape ``text`` for HTML, turning markdown links ``[a](b)`` into anchors."""
    return re.sub(r"\[([^\]]+)\]\(([^)]+)\)", r'<a href="\2">\1</a>', html.escape(text, quote=False))


STYLE = ("body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;line-height:1.4;color:#222}"
         "img{max-width:100%;border:1px solid #ddd}figure{margin:0}figcaption{font-size:.85em;color:#555}"
         ".figs{display:flex;flex-wrap:wrap;gap:1em;align-items:flex-start;margin:1em 0}"
         ".figs figure{flex:1 1 520px;max-width:100%}nav{columns:2;font-size:.95em}"
         "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:.3em .6em;font-size:.9em}"
         "th{background:#f3f3f3}td.supported{background:#e3f6e3}td.not-supported{background:#fbe4e4}")


def _anchor(title: str) -> str:
    """An HTML id for a section title ("Policy flat" → "policy-flat")."""
    return re.sub(r"[^a-z0-9]+", "-", title.lower()).strip("-")


def to_html(blocks: list[Block]) -> str:
    """The page: figures that follow each other share a wrapping row."""
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>Self-righting benchmark report</title>", f"<style>{STYLE}</style></head><body>"]
    in_row = False
    for b in blocks:
        if b[0] != "img" and in_row:
            parts.append("</div>")
            in_row = False
        if b[0] in ("h1", "h2", "h3"):
            anchor = f' id="{_anchor(b[1])}"' if b[0] == "h2" else ""
            parts.append(f"<{b[0]}{anchor}>{html.escape(b[1])}</{b[0]}>")
        elif b[0] == "p":
            parts.append(f"<p>{_inline(b[1])}</p>")
        elif b[0] == "nav":
            items = "".join(f'<li><a href="#{_anchor(t)}">{html.escape(t)}</a></li>' for t in b[1])
            parts.append(f"<nav><ul>{items}</ul></nav>")
        elif b[0] == "img":
            if not in_row:
                parts.append('<div class="figs">')
                in_row = True
            src = html.escape(b[1])  # a click opens the figure at full size
            parts.append(f'<figure><a href="{src}"><img src="{src}" alt="{html.escape(b[2])}"></a>'
                         f"<figcaption>{html.escape(b[2])}</figcaption></figure>")
        elif b[0] == "table":
            head = "".join(f"<th>{html.escape(h)}</th>" for h in b[1])
            body = "".join(
                "<tr>" + "".join(
                    f'<td class="{c.replace(" ", "-")}">{html.escape(c)}</td>' if c in ("supported", "not supported")
                    else f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in b[2])
            parts.append(f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")
    if in_row:
        parts.append("</div>")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
