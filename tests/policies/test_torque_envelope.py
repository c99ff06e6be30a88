"""The DC torque envelope: a policy trained with DC motors, run on the ideal servos."""

import dataclasses

import mujoco
import numpy as np
import pytest
import torch

from selfright.config import BenchmarkConfig, ContextConfig
from selfright.env.observations import JOINT_VEL_SCALE, joint_pos_columns, joint_vel_columns, prev_action_columns
from selfright.env.world import build_world
from selfright.policies.base import Policy
from selfright.policies.multiplexer import ContextMultiplexer
from selfright.policies.registry import fit_motor
from selfright.policies.torque_envelope import TorqueEnvelope, envelope_limits, enveloped_targets
from selfright.robots import get_robot
from selfright.terrain import make_cell

ROBOT = get_robot("a1")
CFG = BenchmarkConfig()
DC = dataclasses.replace(CFG, robot=dataclasses.replace(CFG.robot, motor="dcmotor"))


def test_envelope_gives_full_torque_at_rest_and_none_forward_at_the_no_load_speed():
    low, high = envelope_limits(torch.tensor([0.0, 21.0, -21.0, 10.5]), 33.5, 21.0)
    assert low.tolist() == pytest.approx([-33.5, -33.5, 0.0, -33.5])
    assert high.tolist() == pytest.approx([33.5, 0.0, 33.5, 16.75])


def test_enveloped_targets_give_the_dc_motor_torque_on_the_ideal_servos():
    """At any joint state, the ideal servo driven to the enveloped target exerts exactly the
    force MuJoCo's DC motor exerts driven to the policy's target."""
    ideal = build_world(make_cell(0, 0, CFG.terrain), CFG, ContextConfig(), 0).model
    dc = build_world(make_cell(0, 0, DC.terrain), DC, ContextConfig(), 0).model
    rng = np.random.default_rng(0)
    kp, kd = CFG.robot.kp, CFG.robot.kd
    for _ in range(4):
        q = ROBOT.stand_pose + rng.uniform(-0.3, 0.3, 12)
        qd = rng.uniform(-30.0, 30.0, 12)
        target = q + rng.uniform(-1.5, 1.5, 12)
        moved = enveloped_targets(*(torch.tensor(x) for x in (target, q, qd)), kp, kd, ROBOT.torque_limit,
                                  ROBOT.rated_joint_speed).numpy()
        forces = []
        for model, ctrl in ((dc, target), (ideal, moved)):
            d = mujoco.MjData(model)
            d.qpos[:] = model.qpos0
            d.qpos[2], d.qpos[7:], d.qvel[6:], d.ctrl[:] = 2.0, q, qd, ctrl
            mujoco.mj_forward(model, d)
            forces.append(d.actuator_force.copy())
        np.testing.assert_allclose(forces[1], forces[0], atol=1e-9)
        ideal_force = np.clip(kp * (target - q) - kd * qd, -ROBOT.torque_limit, ROBOT.torque_limit)
        assert np.abs(ideal_force - forces[0]).max() > 1.0  # the envelope did cut some torque


class _Constant(Policy):
    """Always the same action; records the previous action it observed."""

    trained_motor = ("dcmotor", 0.0)
    action_mapping = ("stand", 0.5)
    groups = ("student",)

    def __init__(self, action: torch.Tensor):
        self.action, self.seen = action, []

    def act(self, obs, ids, contexts):
        self.seen.append(obs["student"][:, prev_action_columns(12)].clone())
        return self.action.expand(len(ids), -1).clone()


def _obs(q: np.ndarray, qd: np.ndarray, prev: torch.Tensor) -> dict[str, torch.Tensor]:
    x = torch.zeros(1, 6 + 36)
    x[0, joint_pos_columns(12)] = torch.as_tensor(q - ROBOT.nominal_pose, dtype=torch.float32)
    x[0, joint_vel_columns(12)] = torch.as_tensor(qd * JOINT_VEL_SCALE, dtype=torch.float32)
    x[0, prev_action_columns(12)] = prev
    return {"student": x}


def test_the_wrapped_policy_sees_its_own_previous_action_and_its_torque_is_cut():
    inner = _Constant(torch.full((1, 12), 3.0))  # targets 1.5 rad above the stand pose (in range: the thighs)
    policy = fit_motor(inner, CFG)
    assert isinstance(policy, TorqueEnvelope)
    ids = np.array([0])
    policy.reset(ids)
    q, qd = ROBOT.stand_pose.copy(), np.full(12, 15.0)  # moving toward the targets at 15 rad/s
    a0 = policy.act(_obs(q, qd, torch.zeros(12)), ids, ["flat"])
    target = torch.as_tensor(ROBOT.stand_pose, dtype=torch.float32) + 0.5 * a0[0]
    tau = CFG.robot.kp * (target - torch.as_tensor(q, dtype=torch.float32)) - CFG.robot.kd * 15.0
    thighs = slice(1, 12, 3)  # the others' targets lie past their joint range, clipped first
    assert tau[thighs].numpy() == pytest.approx(np.full(4, 33.5 * (1 - 15.0 / 21.0)), rel=1e-4)
    assert (tau <= 33.5 * (1 - 15.0 / 21.0) + 1e-3).all()
    policy.act(_obs(q, qd, a0[0]), ids, ["flat"])  # the env reports the enveloped action ...
    assert torch.allclose(inner.seen[1], torch.full((1, 12), 3.0))  # ... the policy sees its own
    policy.reset(ids)
    policy.act(_obs(q, qd, torch.zeros(12)), ids, ["flat"])
    assert torch.allclose(inner.seen[2], torch.zeros(1, 12))  # a new episode: no previous action


def test_fit_motor_wraps_only_dc_policies_on_ideal_servos_and_inside_a_multiplexer():
    dc_policy = _Constant(torch.zeros(1, 12))
    assert fit_motor(dc_policy, DC) is dc_policy
    ideal_policy = _Constant(torch.zeros(1, 12))
    ideal_policy.trained_motor = ("ideal", 0.0)
    assert fit_motor(ideal_policy, CFG) is ideal_policy
    sr = fit_motor(ContextMultiplexer({"flat": ideal_policy, "rough": dc_policy}), CFG)
    assert sr.policies["flat"] is ideal_policy and isinstance(sr.policies["rough"], TorqueEnvelope)
    faster = _Constant(torch.zeros(1, 12))
    faster.trained_motor = ("dcmotor", 30.0)
    assert fit_motor(faster, CFG).speed == 30.0


def test_the_envelope_motor_is_the_wrapper_applied_by_the_env():
    """``RobotConfig.motor = "envelope"`` moves any policy's targets as ``TorqueEnvelope`` moves a
    DC-trained policy's on the ideal servos: along a fall, the env's targets are the ones the
    wrapper would have sent the ideal servos from the same states."""
    from selfright.env.recovery_env import RecoveryEnv
    from selfright.train.contexts import make_training_worlds

    w = torch.randn(42, 12, generator=torch.Generator().manual_seed(0)) * 0.3

    class Linear(_Constant):
        def act(self, obs, ids, contexts):
            return torch.tanh(obs["student"] @ w) * 3.0

    env_cfg = dataclasses.replace(CFG, robot=dataclasses.replace(CFG.robot, motor="envelope"))
    policy = Linear(torch.zeros(1, 12))
    assert fit_motor(policy, env_cfg) is policy  # the env applies the limit: no wrapper on top
    wrapped = fit_motor(Linear(torch.zeros(1, 12)), CFG)
    assert isinstance(wrapped, TorqueEnvelope)
    envs = [RecoveryEnv(c, make_training_worlds("flat", c, seed=0), num_envs=1, threads=1) for c in (env_cfg, CFG)]
    ids = np.arange(1)
    envs[0].reset(ids, np.zeros(1, dtype=np.int64), [np.random.default_rng(4)])
    wrapped.reset(ids)
    cut = 0.0
    for _ in range(15):
        obs = envs[0].observe()
        state = envs[0].state.copy()
        want = envs[1]._targets(state, envs[1]._clip(wrapped.act(obs, ids, ["flat"])))
        action = policy.act(obs, ids, ["flat"])
        envs[0].step(action)
        np.testing.assert_allclose(envs[0].last_ctrl, want, atol=1e-5)
        cut = max(cut, float(np.abs(envs[1]._targets(state, envs[1]._clip(action)) - want).max()))
    assert cut > 0.05  # the envelope moved some targets
    for env in envs:
        env.close()
    envelope_trained = _Constant(torch.zeros(1, 12))
    envelope_trained.trained_motor = ("envelope", 0.0)
    assert isinstance(fit_motor(envelope_trained, CFG), TorqueEnvelope)
