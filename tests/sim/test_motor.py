"""The default scene's actuators follow the A1's DC-motor torque-speed envelope; ``ideal``
servos give the full torque at any speed.

The DC motor (``RobotConfig.motor = "dcmotor"``, MuJoCo's ``dcmotor`` actuator) has a drive
voltage that saturates and a current limit at the stall torque τ_s = 33.5 N·m. At joint speed ω
and no-load speed ω₀ = 21 rad/s it gives a torque in
[max(−τ_s, −τ_s (1 + ω/ω₀)), min(τ_s, τ_s (1 − ω/ω₀))]: along the motion at most
τ_s (1 − |ω|/ω₀), which is 0 at |ω| = ω₀ and a braking torque beyond it (the back-EMF exceeds
the drive voltage); against the motion (braking, regenerative) the full τ_s at any speed.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from selfright.config import BenchmarkConfig, ContextConfig, RobotConfig
from selfright.env.world import build_world
from selfright.robots import get_robot
from selfright.terrain import make_cell

ROBOT = get_robot("a1")
STALL, NO_LOAD = 33.5, 21.0
SPEEDS = (0.0, 5.0, 10.5, 15.0, 21.0, 30.0, 42.0)
"""Joint speeds |ω| (rad/s) tested, in both directions."""


def _world(motor: str):
    cfg = BenchmarkConfig()
    cfg = dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, motor=motor))
    return build_world(make_cell(0, 0, cfg.terrain), cfg, ContextConfig(), 0)


def _forces(model: mujoco.MjModel, qd: float, push: float) -> np.ndarray:
    """(J,) actuator torques (N·m) with every joint at the standing pose, turning at ``qd``
    (rad/s), the trunk still in the air, and every target ``push`` rad away: a PD torque far
    beyond the motor's limit, in the sign of ``push``."""
    d = mujoco.MjData(model)
    d.qpos[:7] = [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0]
    d.qpos[7:] = ROBOT.stand_pose
    d.qvel[6:] = qd
    d.ctrl[:] = ROBOT.stand_pose + push
    mujoco.mj_forward(model, d)
    return d.actuator_force.copy()


def test_the_default_motor_is_the_a1s_dc_motor():
    assert RobotConfig().motor == "dcmotor"
    assert ROBOT.torque_limit == STALL and ROBOT.rated_joint_speed == NO_LOAD
    m = _world("dcmotor").model
    assert (m.actuator_gaintype == mujoco.mjtGain.mjGAIN_DCMOTOR).all()
    default = BenchmarkConfig()
    assert (build_world(make_cell(0, 0, default.terrain), default, ContextConfig(), 0).model.actuator_gaintype
            == mujoco.mjtGain.mjGAIN_DCMOTOR).all()


@pytest.mark.parametrize("speed", SPEEDS)
def test_dc_motor_torque_along_the_motion_falls_to_zero_at_the_no_load_speed(speed):
    """Pushing along the motion: τ_s (1 − |ω|/ω₀), full at rest, 0 at 21 rad/s, braking beyond."""
    m = _world("dcmotor").model
    for sign in (1.0, -1.0):
        forces = _forces(m, sign * speed, sign * 5.0)
        np.testing.assert_allclose(forces, sign * STALL * (1.0 - speed / NO_LOAD), atol=1e-6)
    if speed >= NO_LOAD:  # it cannot push along the motion at all
        assert (_forces(m, speed, 5.0) <= 1e-9).all() and (_forces(m, -speed, -5.0) >= -1e-9).all()


@pytest.mark.parametrize("speed", SPEEDS)
def test_dc_motor_brakes_with_the_stall_torque_at_any_speed(speed):
    """Pushing against the motion: the current limit, τ_s, at any speed."""
    m = _world("dcmotor").model
    for sign in (1.0, -1.0):
        np.testing.assert_allclose(_forces(m, sign * speed, -sign * 5.0), -sign * STALL, atol=1e-6)


def test_dc_motor_gives_the_pd_torque_below_its_limit():
    """Inside the envelope the motor delivers the PD law kp (q* − q) − kd q̇."""
    m = _world("dcmotor").model
    cfg = RobotConfig()
    np.testing.assert_allclose(_forces(m, 2.0, 0.2), cfg.kp * 0.2 - cfg.kd * 2.0, atol=1e-6)


@pytest.mark.parametrize("speed", SPEEDS)
def test_ideal_servos_give_the_full_torque_at_any_speed(speed):
    m = _world("ideal").model
    for sign in (1.0, -1.0):
        np.testing.assert_allclose(_forces(m, sign * speed, sign * 5.0), sign * STALL, atol=1e-6)
        np.testing.assert_allclose(_forces(m, sign * speed, -sign * 5.0), -sign * STALL, atol=1e-6)
