"""Standing starts for training episodes (``EpisodeConfig.stand_start``; off by default).

A share of training episodes begins not with the seed's fall but with the robot standing:
trunk square to the local ground at a random heading and spot of the spawn square, joints
near a standing pose, feet just above the ground, and a random trunk velocity, so that it
arrives "upright with momentum" the way the incline policies do before they re-fall
(docs/training.md, *Where the incline robots fall*). The prior art's Go1 get-up task starts
40 % of its episodes from the standing pose for the same reason: a get-up policy must also
learn to stay up. These starts are **not** draws of the seed's fall protocol; evaluation and
validation never use them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from selfright.env.fall import quat_wxyz, sample_spawn_xy
from selfright.env.recovery_env import RecoveryEnv, SettledStarts
from selfright.terrain import Tile

NORMAL_SPAN_M = 0.2
"""Half the span of the finite differences that give the ground's normal under the trunk (m),
about half the trunk's length."""


@dataclass(frozen=True)
class StandDraw:
    """What a standing start draws (all ranges are symmetric and uniform)."""

    tilt_deg: float
    """Largest tilt of the trunk away from square to the ground (deg), about a random
    horizontal axis."""
    joint_noise_rad: float
    """Largest offset of each joint from the standing pose (rad), clipped to its range."""
    lin_vel_mps: float
    """Largest trunk linear velocity per world axis (m/s)."""
    ang_vel_rps: float
    """Largest trunk angular velocity per body axis (rad/s)."""
    clearance_m: float = 0.01
    """Gap under the lowest foot when the episode starts (m)."""


def ground_normal(tile: Tile, xy: np.ndarray, span_m: float = NORMAL_SPAN_M) -> np.ndarray:
    """(3,) unit normal of the ground under ``xy`` (2,), from central differences of the tile's
    heights over ± ``span_m``."""
    dx, dy = np.array([span_m, 0.0]), np.array([0.0, span_m])
    h = tile.height_at(np.stack([xy + dx, xy - dx, xy + dy, xy - dy]))
    gx, gy = (h[0] - h[1]) / (2 * span_m), (h[2] - h[3]) / (2 * span_m)
    n = np.array([-gx, -gy, 1.0])
    return n / np.linalg.norm(n)


def stand_orientation(rng: np.random.Generator, normal: np.ndarray, tilt_deg: float) -> Rotation:
    """A random heading about the trunk's up axis, the up axis along ``normal``, then tilted
    by up to ``tilt_deg`` about a random horizontal axis."""
    yaw = Rotation.from_euler("z", rng.uniform(0.0, 2 * math.pi))
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, normal)
    s = np.linalg.norm(axis)
    align = Rotation.from_rotvec(axis / s * math.atan2(s, normal[2])) if s > 1e-12 else Rotation.identity()
    phi = rng.uniform(0.0, 2 * math.pi)
    tilt = Rotation.from_rotvec(np.array([math.cos(phi), math.sin(phi), 0.0]) * math.radians(rng.uniform(0.0, tilt_deg)))
    return tilt * align * yaw


def stand_qpos_qvel(
    rng: np.random.Generator,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    foot_geoms: list[int],
    tile: Tile,
    pose: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    xy: np.ndarray,
    draw: StandDraw,
) -> tuple[np.ndarray, np.ndarray]:
    """qpos (7 + J) and qvel (6 + J) of one standing start at ``xy``: orientation and joints
    drawn, then the trunk lowered or raised until the lowest foot is ``clearance_m`` above the
    ground under it (``data`` is scratch space for the model's forward kinematics)."""
    quat = quat_wxyz(stand_orientation(rng, ground_normal(tile, xy), draw.tilt_deg))
    q = np.clip(pose + rng.uniform(-draw.joint_noise_rad, draw.joint_noise_rad, size=pose.shape), low, high)
    qpos = np.concatenate([xy, [0.0], quat, q])
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    feet = data.geom_xpos[foot_geoms]
    gap = feet[:, 2] - model.geom_size[foot_geoms, 0] - tile.height_at(feet[:, :2])
    qpos[2] = draw.clearance_m - gap.min()
    qvel = np.zeros(model.nv)
    qvel[:3] = rng.uniform(-draw.lin_vel_mps, draw.lin_vel_mps, size=3)
    qvel[3:6] = rng.uniform(-draw.ang_vel_rps, draw.ang_vel_rps, size=3)
    return qpos, qvel


def stand_starts(
    env: RecoveryEnv, world_idx: np.ndarray, rngs: list[np.random.Generator], models: list[mujoco.MjModel],
    pose: np.ndarray, draw: StandDraw,
) -> SettledStarts:
    """k standing starts (rows aligned with ``world_idx``, ``rngs``, ``models``), each stepped
    one physics step holding its joints so that its sensors read; the clock stands where a
    fall's settle ends, as for every training start."""
    sl, robot, cfg = env.sl, env.robot, env.cfg
    nq = sl.qpos_joints.stop - 1
    init = np.zeros((len(world_idx), sl.size))
    scratch: dict[int, tuple[mujoco.MjData, list[int]]] = {}
    for k, (w, rng) in enumerate(zip(world_idx, rngs, strict=True)):
        world = env.worlds[w]
        if w not in scratch:
            scratch[w] = (mujoco.MjData(world.model), [world.model.geom(g).id for g in robot.foot_geoms])
        data, feet = scratch[w]
        xy = sample_spawn_xy(rng, cfg.fall, cfg.terrain, world.fixed_spawn_y)
        qpos, qvel = stand_qpos_qvel(rng, world.model, data, feet, world.tile, pose, robot.joint_low, robot.joint_high, xy, draw)
        init[k, sl.time] = cfg.fall.settle_s - cfg.sim.timestep_s
        init[k, 1 : 1 + nq] = qpos
        init[k, 1 + nq : 1 + nq + len(qvel)] = qvel
    return env.hold_rollout(models, init, 1)
