import dataclasses

import mujoco
import numpy as np
import pytest

from selfright.config import BenchmarkConfig, ContextConfig
from selfright.env.world import build_world
from selfright.robots import get_robot
from selfright.terrain import make_cell

ROBOT = get_robot("a1")


@pytest.fixture(scope="module")
def world():
    cfg = BenchmarkConfig()
    return build_world(make_cell(0, 0, cfg.terrain), cfg, ContextConfig(), 0)


def test_model_facts(world):
    m = world.model
    trunk = m.body("trunk").id
    robot_bodies = [b for b in range(m.nbody) if m.body_rootid[b] == trunk]
    assert 12.0 <= m.body_mass[robot_bodies].sum() <= 12.6
    assert m.nu == 12
    assert np.allclose(m.actuator_forcerange, [[-33.5, 33.5]] * 12)
    for g in ROBOT.foot_geoms:
        assert m.geom(g).type[0] == mujoco.mjtGeom.mjGEOM_SPHERE
    for j, lo, hi in zip(ROBOT.joint_names, ROBOT.joint_low, ROBOT.joint_high):
        assert m.joint(j).range == pytest.approx([lo, hi])
    robot_geoms = [g for g in range(m.ngeom) if m.body_rootid[m.geom_bodyid[g]] == trunk]
    allowed = {int(mujoco.mjtGeom.mjGEOM_SPHERE), int(mujoco.mjtGeom.mjGEOM_CAPSULE), int(mujoco.mjtGeom.mjGEOM_BOX)}
    assert robot_geoms and all(int(m.geom_type[g]) in allowed for g in robot_geoms)
    assert np.all(m.geom_margin == 0)


def _run(world, qpos, ctrl, steps):
    m = world.model
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    d.ctrl[:] = ctrl
    traj = []
    for _ in range(steps):
        mujoco.mj_step(m, d)
        traj.append(d.qpos.copy())
    return d, np.array(traj)


def test_stands_in_standing_pose_without_drifting(world):
    qpos = np.concatenate([[0, 0, 0.37, 1, 0, 0, 0], ROBOT.stand_pose])
    d, traj = _run(world, qpos, ROBOT.stand_pose, 1200)  # 6 s
    late = traj[400:]  # after landing
    assert np.ptp(late[:, 0]) < 0.01 and np.ptp(late[:, 1]) < 0.01   # no drift
    w, x, y, _ = d.qpos[3:7]
    assert 1 - 2 * (x * x + y * y) > np.cos(np.radians(3))  # trunk within 3° of level
    assert d.qpos[2] > 0.32
    assert np.abs(d.qvel).max() < 0.05
    # Contact sensors: four feet on the ground, no collision (a foot is not a calf collision).
    from selfright.sim.batch import sensor_layout

    so = sensor_layout(world.model, ROBOT)
    assert (d.sensordata[so.foot_contact] > 0).all()
    assert not (d.sensordata[so.body_contact] > 0).any()


def test_stands_in_nominal_pose(world):
    qpos = np.concatenate([[0, 0, 0.32, 1, 0, 0, 0], ROBOT.nominal_pose])
    d, traj = _run(world, qpos, ROBOT.nominal_pose, 1200)
    assert np.ptp(traj[400:, 0]) < 0.01
    assert 0.22 < d.qpos[2] < 0.30
    assert np.abs(d.qvel).max() < 0.05


def test_falls_believably(world):
    # Dropped upside down from one body length: lands, bounces at most a little, comes to rest
    # on its back, never penetrates the ground deeply, never diverges.
    qpos = np.concatenate([[0, 0, 0.5, 0, 1, 0, 0], ROBOT.nominal_pose])
    d, traj = _run(world, qpos, ROBOT.nominal_pose, 600)
    assert np.isfinite(traj).all()
    assert traj[:, 2].min() > 0.0
    assert d.qpos[2] < 0.2
    assert np.abs(d.qvel).max() < 0.5
    assert np.linalg.norm(traj[-1, :2]) < 0.3


def test_stand_height_is_inside_the_goal_set(world):
    """The reward's target height z* (the stand pose's height) lies above the goal-set bar,
    and the stand pose settles within 2 cm of it."""
    cfg = BenchmarkConfig()
    assert ROBOT.stand_height_m > cfg.goal.height_fraction * ROBOT.leg_length_m + 0.02
    qpos = np.concatenate([[0, 0, ROBOT.stand_height_m + 0.02, 1, 0, 0, 0], ROBOT.stand_pose])
    d, _ = _run(world, qpos, ROBOT.stand_pose, 600)
    assert abs(d.qpos[2] - ROBOT.stand_height_m) < 0.02


def test_tall_pose_stands_higher_than_the_stand_pose(world):
    """``--action-reference tall``: action 0 holds straighter legs, settling above the stand
    pose and still on four feet; ``reference_pose`` maps each reference to its pose."""
    heights = []
    for pose in (ROBOT.stand_pose, ROBOT.tall_pose):
        qpos = np.concatenate([[0, 0, 0.40, 1, 0, 0, 0], pose])
        d, _ = _run(world, qpos, pose, 600)
        heights.append(d.qpos[2])
    assert heights[1] > heights[0] + 0.015 and heights[1] < ROBOT.leg_length_m
    np.testing.assert_array_equal(ROBOT.reference_pose("tall"), ROBOT.tall_pose)
    np.testing.assert_array_equal(ROBOT.reference_pose("stand"), ROBOT.stand_pose)
    assert ROBOT.reference_pose("current") is None
    with pytest.raises(ValueError, match="no 'tall' pose"):
        dataclasses.replace(ROBOT, tall_pose=None).reference_pose("tall")


def test_joint_stops_are_hard(world):
    """A motor saturated past a stop (33.5 N·m) holds the joint within 0.03 rad of it. MuJoCo's
    default limit softness (solreflimit 0.02 s) let the knee sit 0.28 rad past its stop."""
    m = world.model
    knees = [m.joint(f"{leg}_calf_joint").id for leg in ("FR", "FL", "RR", "RL")]
    assert np.allclose(m.jnt_solref[knees, 0], BenchmarkConfig().robot.joint_stop_timeconst_s)
    d = mujoco.MjData(m)
    d.qpos[:] = m.qpos0
    d.qpos[2] = 2.0  # trunk in the air, held still below
    d.ctrl[:] = m.jnt_range[1:, 1] + 3.0  # every target far past the upper stop: torques saturate
    for _ in range(400):
        d.qpos[:7] = [0.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0]
        d.qvel[:6] = 0.0
        mujoco.mj_step(m, d)
    assert np.allclose(np.abs(d.actuator_force), 33.5)
    past = d.qpos[m.jnt_qposadr[knees]] - m.jnt_range[knees, 1]
    assert np.all(past < 0.03), past


def test_joint_stop_softer_than_the_physics_step_allows_is_refused():
    cfg = BenchmarkConfig()
    bad = dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, joint_stop_timeconst_s=0.005))
    with pytest.raises(ValueError, match="twice the step"):
        build_world(make_cell(0, 0, bad.terrain), bad, ContextConfig(), 0)


@pytest.fixture(scope="module")
def dc_world():
    cfg = BenchmarkConfig()
    cfg = dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, motor="dcmotor"))
    return build_world(make_cell(0, 0, cfg.terrain), cfg, ContextConfig(), 0)


def test_dc_motors_stand_like_the_ideal_ones_and_stop_at_the_rated_speed(dc_world):
    """RobotConfig(motor="dcmotor"): the same PD stance (torque is delivered exactly below the
    voltage limit), the domain randomiser's gain slots are the controller's kp and kd, and a
    saturated motor turning a leg in the air settles at the rated 21 rad/s (the ideal servo
    does not slow down)."""
    from selfright.env.randomization import DCMOTOR_KD, DCMOTOR_KP, ModelRandomizer

    m = dc_world.model
    assert np.allclose(m.actuator_gainprm[:, DCMOTOR_KP], 50.0) and np.allclose(m.actuator_gainprm[:, DCMOTOR_KD], 1.0)
    r = ModelRandomizer(m, ROBOT)
    assert r.dcmotor and np.allclose(r.apply(m, 1.0, 1.0, 1.2, 0.5).actuator_gainprm[:, DCMOTOR_KP], 60.0)
    qpos = np.concatenate([[0, 0, 0.37, 1, 0, 0, 0], ROBOT.stand_pose])
    d, _ = _run(dc_world, qpos, ROBOT.stand_pose, 800)
    assert d.qpos[2] > 0.32 and np.abs(d.qvel).max() < 0.05
    for world, fast in ((dc_world, False), (_ideal(), True)):
        top = _top_swing_speed(world.model)
        assert (top > 40.0) if fast else (top < ROBOT.rated_joint_speed), top


def _top_swing_speed(mm: mujoco.MjModel) -> float:
    """Fastest FR hip speed (rad/s) while the motor swings its leg back through 2.9 rad with
    the trunk held in the air."""
    dd = mujoco.MjData(mm)
    dd.qpos[:] = mm.qpos0
    dd.qpos[7:] = ROBOT.stand_pose
    dd.ctrl[:] = ROBOT.stand_pose
    dd.ctrl[1] = 3.5
    top = 0.0
    for _ in range(100):
        dd.qpos[:7] = [0.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0]
        dd.qvel[:6] = 0.0
        mujoco.mj_step(mm, dd)
        top = max(top, abs(dd.qvel[7]))
    return top


def test_a_faster_dc_motor_turns_faster_and_a_speed_needs_dc_motors():
    """RobotConfig.motor_speed_rad_s moves the DC motors' zero-torque speed (a curriculum from
    the A1's motors toward the ideal servos); it is refused for the ideal servos."""
    cfg = BenchmarkConfig()
    fast = dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, motor="dcmotor", motor_speed_rad_s=40.0))
    top = _top_swing_speed(build_world(make_cell(0, 0, fast.terrain), fast, ContextConfig(), 0).model)
    assert ROBOT.rated_joint_speed + 5 < top < 40.0, top
    bad = dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, motor="ideal", motor_speed_rad_s=40.0))
    with pytest.raises(ValueError, match="needs motor='dcmotor'"):
        build_world(make_cell(0, 0, bad.terrain), bad, ContextConfig(), 0)


def _ideal():
    cfg = BenchmarkConfig()
    cfg = dataclasses.replace(cfg, robot=dataclasses.replace(cfg.robot, motor="ideal"))
    return build_world(make_cell(0, 0, cfg.terrain), cfg, ContextConfig(), 0)


def test_leg_roots_are_the_thigh_joints_and_a_tall_stance_stands_on_them(world):
    """``leg_roots_m`` (the ``feet_under_hips`` reward term's anchors) are the thigh joints'
    origins at zero abduction in any trunk attitude; the tall pose on a level trunk puts each
    foot straight under its root, and abduction moves it out."""
    m = world.model
    d = mujoco.MjData(m)
    quat = np.array([0.9, 0.2, -0.3, 0.25])
    d.qpos[:7] = [0.4, -0.2, 0.6, *(quat / np.linalg.norm(quat))]
    d.qpos[7:] = ROBOT.tall_pose
    mujoco.mj_kinematics(m, d)
    rot = d.xmat[m.body("trunk").id].reshape(3, 3)
    roots = d.qpos[:3] + ROBOT.leg_roots_m @ rot.T
    thighs = np.array([d.xpos[m.body(g.replace("foot", "thigh")).id] for g in ROBOT.foot_geoms])
    np.testing.assert_allclose(thighs, roots, atol=1e-9)

    d.qpos[3:7] = [1, 0, 0, 0]
    mujoco.mj_kinematics(m, d)
    feet = np.array([d.geom_xpos[m.geom(g).id] for g in ROBOT.foot_geoms])
    np.testing.assert_allclose(feet[:, :2], d.qpos[:2] + ROBOT.leg_roots_m[:, :2], atol=1e-9)
    d.qpos[7::3] = 0.3  # every abduction joint
    mujoco.mj_kinematics(m, d)
    feet = np.array([d.geom_xpos[m.geom(g).id] for g in ROBOT.foot_geoms])
    sideways = np.abs(feet[:, 1] - d.qpos[1] - ROBOT.leg_roots_m[:, 1])
    assert np.all(sideways > 0.05)
