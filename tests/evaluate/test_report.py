"""The seed's claims on synthetic result data, and ``selfright report`` end to end on the tiny grid."""

import json
import re
from pathlib import Path

import pytest

from selfright.cli import main
from selfright.evaluate import claims


def summary(rates: dict[tuple[int, int], float], n: int = 10) -> dict:
    """A summary.json of cells (slope level, roughness level) → success rate; slope level k is 10·k % grade."""
    import math

    cells = [{"slope_level": s, "roughness_level": r, "slope_deg": math.degrees(math.atan(s / 10)), "n": n,
              "successes": round(p * n), "roughness_extent_m": r * 0.5 / 19} for (s, r), p in rates.items()]
    return {"cells": cells}


def yaw_rows(rates: dict[tuple[float, str], float], n: int = 10) -> list[dict]:
    return [{"slope_deg": s, "direction": d, "episodes": n, "hardware_successes": round(p * n)} for (s, d), p in rates.items()]


def test_flat_good_until_pools_inside_and_beyond():
    s = summary({(0, 0): 0.9, (5, 10): 0.7, (6, 0): 0.2, (0, 11): 0.4})
    v = claims.flat_good_until(s)
    assert v.ours == "80 % up to slope level 5 and roughness level 10, 30 % beyond" and v.verdict == "supported"
    assert claims.flat_good_until(summary({(0, 0): 0.4, (6, 0): 0.1})).verdict == "not supported"
    assert claims.flat_good_until(summary({(0, 0): 0.9})).verdict == "n/a"


def test_rough_better_on_rough_compares_the_shared_rough_cells():
    flat = summary({(0, 0): 1.0, (0, 5): 0.2, (2, 5): 0.4})
    rough = summary({(0, 0): 0.0, (0, 5): 0.5, (2, 5): 0.5})
    v = claims.rough_better_on_rough(rough, flat)
    assert v.ours == "π_ROUGH 50 % against π_FLAT 30 % on rough cells" and v.verdict == "supported"
    assert claims.rough_better_on_rough(flat, rough).verdict == "not supported"


def test_rough_struggles_and_incline_gentler():
    assert claims.rough_struggles_on_steep(summary({(0, 3): 0.8, (7, 3): 0.3})).verdict == "supported"
    assert claims.rough_struggles_on_steep(summary({(0, 3): 0.8})).verdict == "n/a"
    v = claims.incline_good_on_gentler(summary({(1, 0): 0.6, (3, 0): 0.8, (4, 0): 0.1, (1, 4): 0.0}))
    assert v.ours == "70 % on smooth slopes below 20°, 10 % at or above" and v.verdict == "supported"


def test_yaw_claims_use_the_hardware_rule():
    seedlike = yaw_rows({(12.0, "down"): 0.8, (12.0, "up"): 0.8, (12.0, "cross"): 0.9,
                         (18.0, "down"): 0.1, (18.0, "up"): 0.4, (18.0, "cross"): 0.7})
    assert claims.cross_most_likely(seedlike).verdict == "supported"
    v = claims.up_helps_on_steeper(seedlike)
    assert v.ours == "above 12°: up 40 %, down 10 %" and v.verdict == "supported"
    flipped = yaw_rows({(12.0, "down"): 0.9, (12.0, "up"): 0.1, (12.0, "cross"): 0.2,
                        (18.0, "down"): 0.5, (18.0, "up"): 0.1, (18.0, "cross"): 0.2})
    assert claims.cross_most_likely(flipped).verdict == "not supported"
    assert claims.up_helps_on_steeper(flipped).verdict == "not supported"
    assert claims.up_helps_on_steeper(yaw_rows({(12.0, "up"): 1.0})).verdict == "n/a"


def test_seed_table_ii_as_printed():
    marks = {s: [d for d, ok in row.items() if ok] for s, row in claims.SEED_TABLE_II.items()}
    assert marks == {12.0: ["down", "up", "cross"], 15.0: ["up", "cross"], 18.0: ["cross"]}


@pytest.fixture(scope="module")
def report(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("report")
    args = ["report", "--grid", "tiny", "--episodes", "2", "--policies", "zero", "open-loop", "--slopes-deg", "12", "18",
            "--threads", "1", "--episode-s", "1", "--hold-s", "0.2", "--no-progress", "--out", str(out)]
    assert main(args) == 0
    return out


def test_report_page_names_only_files_that_exist(report):
    page = (report / "index.html").read_text()
    names = re.findall(r'(?:src|href)="([^"]+)"', page)
    images = re.findall(r'<img src="([^"]+)"', page)
    assert len(images) == 2 * (5 + 1), images  # per policy: 3 heatmaps, 2 histograms, the yaw table
    assert all(f'<a href="{n}"><img src="{n}"' in page for n in images)  # a click opens it full size
    assert "://" not in page  # nothing fetched from the network
    for n in names:
        if n.startswith("#"):  # the list of sections links to the page's own headings
            assert f'id="{n[1:]}"' in page, n
        else:
            assert (report / n).is_file(), n
    assert sum(n.startswith("#") for n in names) == 2 + 2  # a section per policy, Table II, the claims
    md = (report / "report.md").read_text()
    for n in re.findall(r"\]\(([^)]+)\)", md):
        assert (report / n).is_file(), n
    assert page.count("<table>") == 2 + 1  # Table II per policy, the claims
    assert "Cross-slope is the most likely to succeed" in page and "seed ✓" in page


def test_report_resumes_without_simulating_and_writes_the_same_page(report, capsys):
    before = (report / "report.md").read_text()
    manifest = json.loads((report / "report.json").read_text())
    assert [p["folder"] for p in manifest["policies"]] == ["zero", "open-loop"]
    assert {b["context"] for b in manifest["context_boxes"]} == {"flat", "rough", "incline"}
    args = ["report", "--grid", "tiny", "--episodes", "2", "--policies", "zero", "open-loop", "--slopes-deg", "12", "18",
            "--threads", "1", "--episode-s", "1", "--hold-s", "0.2", "--no-progress", "--out", str(report)]
    assert main(args) == 0
    assert (report / "report.md").read_text() == before


def test_report_refuses_an_unknown_policy_in_one_line(tmp_path, capsys):
    assert main(["report", "--grid", "tiny", "--policies", "nope", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown policy 'nope'" in err[0]


def test_published_report_leaves_out_the_episode_files_and_their_links(report, tmp_path):
    import runpy

    publish = runpy.run_path(str(Path(__file__).resolve().parents[2] / "scripts" / "publish_report.py"))["publish"]
    dest = tmp_path / "docs_report"
    files = publish(report, dest)
    kept = {p.relative_to(report) for p in report.rglob("*") if p.is_file() and p.name != "episodes.csv"}
    assert files and {p.relative_to(dest) for p in files} == kept
    page, md = (dest / "index.html").read_text(), (dest / "report.md").read_text()
    names = [n for n in re.findall(r'(?:src|href)="([^"]+)"', page) if not n.startswith("#")]
    links = re.findall(r"\]\(([^)]+)\)", md)
    assert names and links and all((dest / n).is_file() for n in names + links)
    assert "episodes.csv" in (report / "index.html").read_text()  # the report itself links them
    assert "summary.json" in page and "episodes.csv" not in page and "episodes.csv" not in md
    dropped = {"index.html": r', <a href="[^"]+/episodes\.csv">[^<]*</a>', "report.md": r", \[[^\]]*\]\([^)]+/episodes\.csv\)"}
    for name, link in dropped.items():  # otherwise the report's own pages
        assert (dest / name).read_text() == re.sub(link, "", (report / name).read_text()), name
