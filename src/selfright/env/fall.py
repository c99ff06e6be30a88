"""The seed's fall protocol (§V): random inverted orientation, random collision-free joints,
drop from one body length above the local ground."""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from selfright.config import FallConfig, TerrainConfig
from selfright.robots import RobotSpec
from selfright.terrain import Tile

FLIP_Y = Rotation.from_euler("y", np.pi)


def sample_orientation(rng: np.random.Generator) -> Rotation:
    """Uniform on SO(3); if the trunk's up axis points up (+z component > 0), rotate the
    result by 180° about the world +y axis, which inverts it (seed §V)."""
    rot = Rotation.random(random_state=rng)
    return flip_if_upright(rot)


def flip_if_upright(rot: Rotation) -> Rotation:
    up = rot.apply([0.0, 0.0, 1.0])
    return FLIP_Y * rot if up[2] > 0 else rot


def quat_wxyz(rot: Rotation) -> np.ndarray:
    x, y, z, w = rot.as_quat()
    return np.array([w, x, y, z])


class SelfCollisionChecker:
    """Counts robot–robot contacts of a joint configuration on the robot model alone."""

    def __init__(self, robot: RobotSpec):
        self.model = mujoco.MjModel.from_xml_string(robot.mjcf(1.0, 0.0))
        self.data = mujoco.MjData(self.model)
        self._joint_adr = np.array([self.model.joint(j).qposadr[0] for j in robot.joint_names])

    def collides(self, q: np.ndarray) -> bool:
        self.data.qpos[:] = self.model.qpos0
        self.data.qpos[self._joint_adr] = q
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_collision(self.model, self.data)
        return self.data.ncon > 0


def sample_joints(
    rng: np.random.Generator, robot: RobotSpec, checker: SelfCollisionChecker, max_tries: int
) -> np.ndarray:
    """Joint angles uniform within limits, rejection-sampled until free of self-collision."""
    for _ in range(max_tries):
        q = rng.uniform(robot.joint_low, robot.joint_high)
        if not checker.collides(q):
            return q
    raise RuntimeError(f"no self-collision-free joint sample in {max_tries} tries")


def sample_spawn_xy(rng: np.random.Generator, fall: FallConfig, terrain: TerrainConfig, fixed_y: bool) -> np.ndarray:
    """(x, y) ~ U(low, high) of the central spawn square; y = 0 between side walls."""
    u = rng.uniform(fall.spawn_low, fall.spawn_high, size=2)
    xy = (u - 0.5) * terrain.spawn_size_m
    if fixed_y:
        xy[1] = 0.0
    return xy


def initial_qpos(
    rng: np.random.Generator,
    robot: RobotSpec,
    checker: SelfCollisionChecker,
    tile: Tile,
    fall: FallConfig,
    terrain: TerrainConfig,
    fixed_y: bool,
) -> np.ndarray:
    """Full qpos (7 + num_joints) of one fall: position, orientation (w, x, y, z), joints.

    The trunk origin starts ``drop_height_m`` above the highest ground within one body
    length of the spawn point, so no limb starts inside the ground.
    """
    xy = sample_spawn_xy(rng, fall, terrain, fixed_y)
    quat = quat_wxyz(sample_orientation(rng))
    q = sample_joints(rng, robot, checker, fall.max_joint_tries)
    z = tile.max_height_near(xy[None], robot.body_length_m)[0] + fall.drop_height_m
    return np.concatenate([xy, [z], quat, q])
