"""``selfright replay``: one evaluated episode replayed alone gives the same outcome as its
row of episodes.csv, its record is complete, and the renderer draws it."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from selfright.cli import main
from selfright.config import BenchmarkConfig, GoalConfig
from selfright.evaluate.replay import TRACE_COLUMNS, replay_episode, select_cell, write_replay
from selfright.evaluate.runner import evaluate_grid
from selfright.plots.trace import plot_trace
from selfright.policies.registry import make_policy

CFG = BenchmarkConfig(goal=GoalConfig(episode_s=3.0, hold_s=0.5))  # short enough that `rough` misses some on the plane


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory):
    out = tmp_path_factory.mktemp("eval")
    evaluate_grid(make_policy("rough", CFG), policy_name="rough", grid="flat", episodes=6, seed=0, out_dir=out, cfg=CFG,
                  progress=False)
    with open(out / "episodes.csv", newline="") as f:
        return list(csv.DictReader(f))  # 6 episodes: successes and failures, to replay both


@pytest.fixture(scope="module")
def replayed(tmp_path_factory):
    out = tmp_path_factory.mktemp("replay")
    cell = select_cell("flat", CFG, None, None)
    r = replay_episode(make_policy("rough", CFG), CFG, cell, 2, seed=0)
    write_replay(out, r, {"policy": "rough", "grid": "flat", "seed": 0}, CFG)
    plot_trace(out)
    return out, r


def test_replay_reproduces_each_evaluated_episode(evaluated):
    cell = select_cell("flat", CFG, None, None)
    policy = make_policy("rough", CFG)
    assert any(r["success"] == "1" for r in evaluated) and any(r["success"] == "0" for r in evaluated)
    for row in evaluated:
        r = replay_episode(policy, CFG, cell, int(row["episode"]), seed=0)
        assert r.episode_seed == int(row["seed"])
        assert r.success == (row["success"] == "1")
        if r.success:
            assert f"{r.ttr_s:.6g}" == row["ttr_s"] and f"{r.dtr_m:.6g}" == row["dtr_m"]
            # The record ends on the step that completed the hold, all of it in the goal set.
            hold = round(CFG.goal.hold_s / CFG.sim.control_dt_s)
            assert r.trace["in_goal"][-hold:].all() and not r.trace["in_goal"][-hold - 1]
            assert r.trace["t_s"][-hold] == pytest.approx(r.ttr_s)


def test_replay_files(replayed):
    out, r = replayed
    rec = np.load(out / "trajectory.npz")
    assert rec["states"].shape[0] == len(r.trace["t_s"]) == json.loads((out / "replay.json").read_text())["control_steps"] + 1
    assert np.allclose(np.diff(rec["t_s"]), CFG.sim.control_dt_s)
    with open(out / "trace.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == TRACE_COLUMNS and len(rows) == len(rec["states"])
    # The first row is the settled fall: lying, not in the goal set.
    assert rows[0]["t_s"] == "0" and rows[0]["in_goal"] == "0"
    meta = json.loads((out / "replay.json").read_text())
    assert meta["episode"] == 2 and meta["goal_height_m"] == pytest.approx(0.32)
    assert meta["benchmark_version"] == 1 and meta["goal_height_ref"] == "feet"
    if r.success:  # the goal set reads the height over the feet, so the whole hold clears the bar
        assert meta["hold_min_height_over_feet_m"] >= meta["goal_height_m"]
    else:
        assert meta["hold_min_height_over_feet_m"] is None
    assert (out / "trace.png").stat().st_size > 10_000 and (out / "scene.xml").exists()


def test_render_draws_the_robot(replayed, tmp_path):
    out, r = replayed
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    cmd = [sys.executable, "-m", "selfright.evaluate.render", str(out), "--width", "96", "--height", "72", "--fps", "10"]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if proc.returncode != 0 and any(k in proc.stderr for k in ("OpenGL", "EGL", "GLFW", "libGL")):
        pytest.skip(f"no offscreen OpenGL here: {proc.stderr.strip().splitlines()[-1]}")
    assert proc.returncode == 0, proc.stderr
    from PIL import Image, ImageSequence

    gif = Image.open(out / "episode.gif")
    frames = [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(gif)]
    assert len(frames) == -(-len(r.states) // 5)  # 50 Hz record at 10 frames/s
    first = frames[0].astype(float)
    assert first.shape == (72, 96, 3) and first.std() > 10  # not a blank image
    # The trunk (orange) is in view, near the middle where the camera looks.
    orange = (first[..., 0] > 150) & (first[..., 1] > 80) & (first[..., 1] < 170) & (first[..., 2] < 80)
    assert orange[18:54, 24:72].sum() > 10
    assert (out / "filmstrip.png").stat().st_size > 5_000


def test_cli_replay_and_cell_choice(tmp_path, capsys):
    out = tmp_path / "r"
    code = main(["replay", "--policy", "zero", "--grid", "tiny", "--slope-level", "1", "--roughness-level", "0",
                 "--episode", "1", "--episode-s", "0.5", "--out", str(out), "--no-video"])
    assert code == 0
    assert "episode 1 of slope 10 %" in capsys.readouterr().out
    assert (out / "trace.png").exists() and not (out / "episode.gif").exists()
    code = main(["replay", "--policy", "zero", "--grid", "rough", "--out", str(tmp_path / "x"), "--no-video"])
    err = capsys.readouterr().err
    assert code == 2 and "3 cells of grid 'rough' match" in err and "--roughness-level 8" in err
