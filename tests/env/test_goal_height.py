"""The goal set's body height on physics states set by hand in the real scene: the trunk origin
above the mean of the four feet's lowest points, along gravity, checked against positions read
from MuJoCo directly, with the goal-set verdicts that follow (and, for comparison, those of the
height over the terrain beneath the trunk)."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from selfright.config import BenchmarkConfig, ContextConfig, GoalConfig
from selfright.env.goal import goal_height_m, robot_in_goal_set
from selfright.env.recovery_env import RecoveryEnv
from selfright.env.world import World, build_world
from selfright.robots import get_robot
from selfright.sim.batch import STATE_SPEC
from selfright.sim.scene import scene_mjcf
from selfright.terrain import grid_cells

CFG = BenchmarkConfig()
ROBOT = get_robot("a1")
BAR = goal_height_m(CFG.goal, ROBOT.leg_length_m)  # 0.32 m
STAND = ROBOT.stand_pose
CROUCH = np.tile([0.0, 0.74, -1.48], 4)
"""Legs under the hips, bent: the trunk stands ~0.32 m from the plane of the feet."""


def world(grid: str, dent_m: float = 0.0) -> World:
    """The grid's (first) world; ``dent_m`` ≠ 0 raises (> 0) or lowers (< 0) a 0.1 m square of
    ground centred under the origin, between the feet of a robot standing there."""
    w = build_world(grid_cells(grid, CFG.terrain)[0], CFG, ContextConfig(), 0)
    if not dent_m:
        return w
    h = w.tile.heights.copy()
    c = h.shape[0] // 2
    h[c - 1 : c + 2, c - 1 : c + 2] += dent_m
    tile = dataclasses.replace(w.tile, heights=h)
    xml = scene_mjcf(ROBOT, tile, w.context, CFG.robot, CFG.sim)
    return World(cell=w.cell, tile=tile, context=w.context, model=mujoco.MjModel.from_xml_string(xml), xml=xml)


def pitch_quat(angle: float) -> np.ndarray:
    """Trunk turned about world y by ``angle`` (rad): its up axis tilts toward −x for angle < 0."""
    return np.array([math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0])


def place(w: World, joints: np.ndarray, quat: np.ndarray) -> tuple[RecoveryEnv, mujoco.MjData]:
    """An env whose one slot holds the robot at the origin with ``joints`` and trunk ``quat``,
    lowered until every foot sphere sinks 1 mm into the ground (normal to the tile's plane)."""
    model = w.model
    data = mujoco.MjData(model)
    feet = [model.geom(g).id for g in ROBOT.foot_geoms]
    data.qpos[:3] = (0.0, 0.0, 1.0)
    data.qpos[3:7] = quat
    data.qpos[7:] = joints
    mujoco.mj_kinematics(model, data)
    cos_a = math.cos(math.atan(w.tile.slope_pct / 100.0))
    centres = data.geom_xpos[feet]
    gap = (centres[:, 2] - w.tile.height_at(centres[:, :2])) * cos_a - model.geom_size[feet, 0]
    data.qpos[2] -= (gap.max() + 0.001) / cos_a
    mujoco.mj_forward(model, data)
    env = RecoveryEnv(CFG, [w], 1, threads=1)
    state = np.empty(mujoco.mj_stateSize(model, STATE_SPEC))
    mujoco.mj_getState(model, data, state, STATE_SPEC)
    env.state[0] = state
    env.sens[0] = data.sensordata
    return env, data


def check(w: World, joints: np.ndarray, quat: np.ndarray) -> tuple[float, float, bool, bool]:
    """(height over the feet, height over the terrain, in the goal set, in it by the terrain
    height) of the hand-set state; the first checked against MuJoCo's geom positions."""
    env, data = place(w, joints, quat)
    ids = np.zeros(1, dtype=np.int64)
    rs = env.robot_state(ids)
    feet = [w.model.geom(g).id for g in ROBOT.foot_geoms]
    lowest = data.geom_xpos[feet, 2] - w.model.geom_size[feet, 0]
    want = data.qpos[2] - lowest.mean()
    assert float(rs.height_over_feet[0]) == pytest.approx(want, abs=1e-6)
    assert bool(rs.feet_contact[0].all()), "every foot is on the ground"
    terrain = dataclasses.replace(CFG.goal, height_ref="terrain")
    verdict = bool(robot_in_goal_set(rs, CFG.goal, ROBOT.leg_length_m)[0])
    by_terrain = bool(robot_in_goal_set(rs, terrain, ROBOT.leg_length_m)[0])
    env.close()
    return want, float(rs.height_over_terrain[0]), verdict, by_terrain


def test_default_goal_set_reads_the_height_over_the_feet():
    assert GoalConfig().height_ref == "feet"


def test_standing_on_flat_ground():
    over_feet, over_terrain, ok, ok_terrain = check(world("flat"), STAND, pitch_quat(0.0))
    assert over_feet == pytest.approx(ROBOT.stand_height_m, abs=0.01)
    assert over_terrain == pytest.approx(over_feet, abs=2e-3)  # on flat ground the two agree
    assert ok and ok_terrain


def test_crouch_square_to_a_20_degree_slope_is_not_in_the_goal_set():
    w = world("incline")
    assert math.degrees(math.atan(w.tile.slope_pct / 100.0)) == pytest.approx(20.0)
    over_feet, over_terrain, ok, ok_terrain = check(w, CROUCH, pitch_quat(-math.radians(20.0)))
    assert 0.29 < over_feet < BAR  # ~0.30 m over its feet
    assert over_terrain >= BAR  # the ground under the trunk lies ~4 cm below the feet
    assert not ok and ok_terrain


def test_standing_over_a_bump_is_in_the_goal_set():
    over_feet, over_terrain, ok, ok_terrain = check(world("flat", dent_m=0.05), STAND, pitch_quat(0.0))
    assert over_feet >= BAR and over_terrain < BAR
    assert ok and not ok_terrain


def test_crouch_over_a_hollow_is_not_in_the_goal_set():
    over_feet, over_terrain, ok, ok_terrain = check(world("flat", dent_m=-0.05), CROUCH, pitch_quat(0.0))
    assert over_feet < BAR <= over_terrain
    assert not ok and ok_terrain
