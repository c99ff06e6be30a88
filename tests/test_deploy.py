"""A shipped student exported to ONNX and run by ``selfright.deploy.OnnxController`` from raw
sensor readings (trunk quaternion, gyro, joint angles and speeds) commands the joint targets that
``selfright evaluate`` commands on the same states."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from selfright.config import BenchmarkConfig
from selfright.deploy import OnnxController, gravity_in_body, main, read_spec
from selfright.env.recovery_env import RecoveryEnv
from selfright.env.world import build_world
from selfright.evaluate.runner import context_config
from selfright.policies.registry import make_policy
from selfright.terrain.grid import grid_cells
from selfright.train.commands import ExportArgs, export


def _export(name: str, where: Path) -> Path:
    onnx_path, _ = export(ExportArgs(checkpoint=Path(name), onnx=where / f"{name}.onnx"))
    return onnx_path


@pytest.mark.parametrize("name", ["flat", "rough", "incline"])
def test_controller_commands_the_benchmarks_targets(name, tmp_path):
    cfg = BenchmarkConfig()
    ctrl = OnnxController(_export(name, tmp_path))
    policy = make_policy(name, cfg)
    cell = grid_cells("tiny", cfg.terrain)[3]  # sloped and rough
    env = RecoveryEnv(cfg, [build_world(cell, cfg, context_config(cfg), 0)], 1, threads=1)
    ids = np.arange(1)
    env.reset(ids, np.zeros(1, dtype=np.int64), [np.random.default_rng(7)])
    policy.reset(ids)
    sl, errors, targets = env.sl, [], []
    for step in range(60):
        st = env.state[0]
        raw = st[sl.quat], st[sl.ang_vel], st[sl.qpos_joints], st[sl.qvel_joints]
        obs = env.observe(ids, policy.groups)
        if step == 0:  # the frame the controller builds is the env's student observation
            np.testing.assert_allclose(ctrl.frame(*raw), obs["student"][0].numpy(), atol=1e-5)
        target = ctrl.step(*raw)
        env.step(policy.act(obs, ids, [name]))
        errors.append(np.abs(env.last_ctrl[0] - target).max())
        targets.append(target)
    env.close()
    assert max(errors) < 1e-4, f"largest target difference {max(errors):.2e} rad"
    assert np.ptp(np.array(targets), axis=0).max() > 0.3  # the policy moved: the check had something to compare


def test_gravity_in_body_is_minus_z_upright_and_turns_with_the_trunk():
    np.testing.assert_allclose(gravity_in_body(np.array([1.0, 0, 0, 0])), [0, 0, -1], atol=1e-12)
    # rolled 90° about x: the body's y axis points up, so gravity lies along its −y
    half = np.pi / 4
    g = gravity_in_body(np.array([np.cos(half), np.sin(half), 0, 0]))
    np.testing.assert_allclose(g, [0, -1, 0], atol=1e-12)


def test_export_by_name_writes_the_contract_and_a_teacher_has_none(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    onnx_path, _ = export(ExportArgs(checkpoint=Path("incline")))
    assert onnx_path == Path("incline.onnx") and onnx_path.exists()
    spec = read_spec(onnx_path)
    assert spec.motor == "dcmotor" and spec.motor_speed_rad_s == 21.0 and spec.control_hz == 50.0
    assert len(spec.obs_columns) == 6 + 3 * len(spec.joint_names)
    assert main([str(onnx_path)]) == 0 and '"action_reference"' in capsys.readouterr().out
    teacher, _ = export(ExportArgs(checkpoint=Path("incline-teacher")))
    with pytest.raises(ValueError, match="no deployment contract"):
        read_spec(teacher)
    assert main([str(teacher)]) == 1
