"""``selfright compare``: policies matched fall by fall."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from selfright.cli import main
from selfright.evaluate.compare import mcnemar_p, read_outcomes, report


def fake_eval(folder: Path, policy: str, seed: int, ok: list[int], motor: str = "ideal") -> Path:
    folder.mkdir(parents=True)
    summary = {"policy": policy, "grid": "rough", "seed": seed, "config": {"robot": {"motor": motor}, "eval": {}}}
    (folder / "summary.json").write_text(json.dumps(summary))
    (folder / "episodes.csv").write_text("slope_level,roughness_level,episode,success\n"
                                         + "".join(f"0,{4 * (1 + e % 2)},{e},{s}\n" for e, s in enumerate(ok)))
    return folder


def test_seeds_pool_per_policy_and_the_paired_test_counts_discordant_falls(tmp_path: Path):
    a = [fake_eval(tmp_path / f"a{s}", "A", s, [1, 1, 1, 0]) for s in (0, 1)]
    b = [fake_eval(tmp_path / f"b{s}", "B", s, [1, 0, 0, 0]) for s in (0, 1)]
    o = read_outcomes([*a, *b])
    assert o.names == ["A on rough", "B on rough"] and o.ok.shape == (2, 8) and o.config_differs == []
    text = report(o, by_cell=True)
    assert "8 shared falls (seeds 0, 1)" in text
    assert " 75.0% [" in text and " 25.0% [" in text
    assert "( 0,  4) n=   4  100.0%   50.0%" in text  # episodes 0 and 2 of each seed
    assert f"only A on rough got up in 4, only B on rough in 0; McNemar p = {mcnemar_p(4, 0):.3f}" in text


def test_a_different_motor_is_said_and_unmatched_folders_refused(tmp_path: Path):
    a = fake_eval(tmp_path / "a", "A", 0, [1, 0])
    b = fake_eval(tmp_path / "b", "B", 0, [1, 1], motor="dcmotor")
    assert "configurations differ in robot" in report(read_outcomes([a, b]))
    with pytest.raises(ValueError, match="share no episode"):
        read_outcomes([a, fake_eval(tmp_path / "c", "C", 5, [1])])
    with pytest.raises(ValueError, match="not a finished"):
        read_outcomes([a, tmp_path])


def test_mcnemar_p_is_the_exact_binomial_tail():
    assert mcnemar_p(0, 0) == 1.0
    assert mcnemar_p(5, 5) == 1.0
    assert mcnemar_p(0, 5) == pytest.approx(2 / 32)  # 2 · 0.5⁵
    assert mcnemar_p(10, 2) == pytest.approx(2 * (1 + 12 + 66) / 4096)
    assert mcnemar_p(948, 648) < 1e-12 and mcnemar_p(700, 720) > 0.5  # thousands of falls: no float overflow


def test_cli_compare_prints_the_report_and_exits_2_on_user_errors(tmp_path: Path, capsys):
    a = fake_eval(tmp_path / "a", "A", 0, [1, 0])
    b = fake_eval(tmp_path / "b", "B", 0, [0, 0])
    assert main(["compare", str(a), str(b)]) == 0
    assert "McNemar p = 1.000" in capsys.readouterr().out
    assert main(["compare", str(a)]) == 2
    assert "at least two policies" in capsys.readouterr().err


def test_difference_heatmap_gives_each_cell_the_second_policy_minus_the_first(tmp_path: Path, capsys):
    from selfright.plots.heatmaps import success_difference

    cells = [{"slope_level": 0, "roughness_level": r, "slope_pct": 0, "slope_deg": 0.0, "roughness_R": 0.0}
             for r in (4, 8)]
    folders = []
    for name, ok in (("A", [1, 1] * 6), ("B", [0, 1] * 6)):  # level 4: even episodes; level 8: odd ones
        f = fake_eval(tmp_path / name, name, 0, ok)
        summary = json.loads((f / "summary.json").read_text())
        (f / "summary.json").write_text(json.dumps({**summary, "cells": cells}))
        folders.append(f)
    grid, diff, marks, o = success_difference(folders)
    assert o.names == ["A on rough", "B on rough"]
    assert diff.tolist() == [[-100.0, 0.0]] and marks.tolist() == [["*", ""]]  # 6 of 6 only A: p = 2/64
    png = tmp_path / "d.png"
    assert main(["compare", *map(str, folders), "--plot", str(png)]) == 0 and png.stat().st_size > 0
    assert f"difference heatmap: {png}" in capsys.readouterr().out
    with pytest.raises(ValueError, match="exactly two policies"):
        success_difference([*folders, fake_eval(tmp_path / "C", "C", 0, [1] * 12)])
