"""The report page's pieces: training-context boxes on the grid, data links, markdown and HTML output."""

import math

from selfright.plots.heatmaps import build_grid
from selfright.plots.report_page import box_cells, data_links, grid_boxes, to_html, to_markdown

BOXES = [
    {"context": "flat", "slope_deg": 0.0, "extent_low_m": 0.0, "extent_high_m": 0.0},
    {"context": "rough", "slope_deg": 0.0, "extent_low_m": 1e-9, "extent_high_m": 0.35},
    {"context": "incline", "slope_deg": 20.0, "extent_low_m": 0.0, "extent_high_m": 0.0},
]


def cells(slope_levels, roughness_levels):
    return [{"slope_level": s, "roughness_level": r, "slope_pct": 10.0 * s, "slope_deg": math.degrees(math.atan(s / 10)),
             "roughness_extent_m": 0.5 * r / 19, "roughness_R": float(r)} for s in slope_levels for r in roughness_levels]


def test_boxes_cover_the_training_contexts_cells():
    quick = cells(range(0, 11, 2), range(0, 20, 2))
    assert [(c["slope_level"], c["roughness_level"]) for c in box_cells(quick, BOXES[0])] == [(0, 0)]
    assert [c["roughness_level"] for c in box_cells(quick, BOXES[1])] == [2, 4, 6, 8, 10, 12]  # extents ≤ 0.35 m
    assert [(c["slope_level"], c["roughness_level"]) for c in box_cells(quick, BOXES[2])] == [(4, 0)]  # 21.8°, nearest 20°
    assert box_cells(cells((0, 1), (0, 1)), BOXES[2]) == []  # the tiny grid has no slope near 20°
    grid = build_grid(quick)
    assert grid_boxes(grid, quick, BOXES) == [("flat", 0, 0, 0), ("rough", 0, 1, 6), ("incline", 2, 0, 0)]


def test_markdown_and_html_carry_the_same_blocks():
    blocks = [("h1", "T"), ("p", "see [a.csv](a.csv) & more"), ("img", "x/y.png", "cap"),
              ("table", ["claim", "verdict"], [["c", "supported"]])]
    md, page = to_markdown(blocks), to_html(blocks)
    assert "# T" in md and "![cap](x/y.png)" in md and "| c | supported |" in md
    assert '<a href="a.csv">a.csv</a> &amp; more' in page and '<img src="x/y.png"' in page
    assert '<td class="supported">supported</td>' in page


def test_data_links_name_only_files_that_exist(tmp_path):
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "summary.json").write_text("{}")
    assert data_links(tmp_path, ["p/summary.json", "p/episodes.csv"]) == "Data: [p/summary.json](p/summary.json)."
    assert data_links(tmp_path, ["p/episodes.csv"]) == ""
