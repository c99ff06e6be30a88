"""``selfright replay`` writes what checks an episode without this package: ``scene.xml`` (the
episode's tile and robot, self-contained MJCF) and ``trajectory.npz`` (its full physics states
with ``t_s``). MuJoCo alone, loading the two, puts the robot where the trace says it was."""

from __future__ import annotations

import csv

import mujoco
import numpy as np
import pytest

from selfright.cli import main


def test_replay_scene_and_states_load_in_plain_mujoco(tmp_path, capsys):
    out = tmp_path / "r"
    code = main(["replay", "--policy", "zero", "--grid", "tiny", "--slope-level", "1", "--roughness-level", "0",
                 "--episode", "0", "--episode-s", "0.5", "--threads", "1", "--out", str(out), "--no-video"])
    assert code == 0, capsys.readouterr().err
    model = mujoco.MjModel.from_xml_path(str(out / "scene.xml"))  # no assets or includes needed
    assert (model.actuator_gaintype == mujoco.mjtGain.mjGAIN_DCMOTOR).all()  # the benchmark's motors
    rec = np.load(out / "trajectory.npz")
    states, t_s = rec["states"], rec["t_s"]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    assert states.shape == (len(t_s), mujoco.mj_stateSize(model, spec)) and t_s[0] == 0.0
    with open(out / "trace.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(states)
    data = mujoco.MjData(model)
    trunk = model.body("trunk").id
    for state, row in zip(states, rows):
        mujoco.mj_setState(model, data, state, spec)
        mujoco.mj_forward(model, data)
        xyz = [float(row[k]) for k in ("x_m", "y_m", "z_m")]
        np.testing.assert_allclose(data.xpos[trunk], xyz, atol=1e-6)
        assert data.time - states[0][0] == pytest.approx(float(row["t_s"]), abs=1e-9)  # one clock with the trace
