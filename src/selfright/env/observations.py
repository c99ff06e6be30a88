"""Observation groups. Teacher and student differ only by which groups they read.

student (what a real A1 senses): projected gravity (3), IMU angular velocity (3), joint
    angles relative to the nominal pose (J), joint velocities (J), previous action (J).
teacher: student + privileged context: slope angle (1) and uphill direction in the body
    frame (3), ground friction (1), trunk linear velocity in the body frame (3), body
    height over the feet (1, ``RobotState.height_over_feet``), height scan around the trunk (S), and the randomised
    mass / Kp / Kd factors (3).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from selfright.env.robot_state import RobotState

SCAN_GRID = 5
"""Height-scan points per side (a SCAN_GRID × SCAN_GRID square)."""
SCAN_SPACING_M = 0.15
"""Spacing of the height scan (m), a square of 0.6 m side centred under the trunk."""
JOINT_VEL_SCALE = 0.1
"""Joint velocities are multiplied by this to keep observations O(1)."""
SENSOR_NOISE_STD = {"projected_gravity": 0.05, "ang_vel_rad_s": 0.2, "joint_pos_rad": 0.01, "joint_vel_rad_s": 1.5}
"""Standard deviations of additive Gaussian sensor noise at scale 1, per sensor, in the sensors'
units; the previous action is the policy's own and gets none. ``sensor_noise_std`` lays them out
over the student columns. The values are legged_gym's ``noise_scales``, which that code uses as
the half-widths of *uniform* noise (standard deviation 1/√3 of them): scale 1 here is √3 ≈ 1.7
times its spread, with Gaussian tails, and scale 0.58 matches its standard deviation."""


def scan_offsets() -> np.ndarray:
    """(S, 2) x-y offsets of the height scan, in the trunk's yaw frame (m)."""
    r = (np.arange(SCAN_GRID) - (SCAN_GRID - 1) / 2) * SCAN_SPACING_M
    gx, gy = np.meshgrid(r, r, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def scan_points(rs: RobotState) -> np.ndarray:
    """(n, S, 2) world x-y of the height-scan points, rotated with the trunk's heading."""
    heading = rs.rot[:, :, 0].numpy().astype(np.float64)
    yaw = np.arctan2(heading[:, 1], heading[:, 0])
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    off = scan_offsets()
    x = rs.pos[:, 0:1].numpy() + c * off[None, :, 0] - s * off[None, :, 1]
    y = rs.pos[:, 1:2].numpy() + s * off[None, :, 0] + c * off[None, :, 1]
    return np.stack([x, y], axis=-1)


def student_obs(rs: RobotState, nominal: torch.Tensor, prev_action: torch.Tensor) -> torch.Tensor:
    """(n, 6 + 3J) sensor-only observation."""
    return torch.cat(
        [rs.projected_gravity, rs.ang_vel, rs.q - nominal, rs.qd * JOINT_VEL_SCALE, prev_action], dim=-1
    )


def sensor_noise_std(num_joints: int) -> torch.Tensor:
    """(6 + 3J,) noise std of each ``student`` column at scale 1 (``SENSOR_NOISE_STD``, joint
    velocities scaled by ``JOINT_VEL_SCALE`` as the observation is)."""
    n = SENSOR_NOISE_STD
    return torch.tensor(
        [n["projected_gravity"]] * 3 + [n["ang_vel_rad_s"]] * 3 + [n["joint_pos_rad"]] * num_joints
        + [n["joint_vel_rad_s"] * JOINT_VEL_SCALE] * num_joints + [0.0] * num_joints,
        dtype=torch.float32,
    )


GRAVITY_COLUMNS = slice(0, 3)
"""Columns of the projected gravity (the gravity direction in the trunk frame, (0, 0, −1) upright)
in the student observation (and the teacher's, which starts with it)."""
ANG_VEL_COLUMNS = slice(3, 6)
"""Columns of the IMU's angular velocity (rad/s, trunk frame)."""


def joint_pos_columns(num_joints: int) -> slice:
    """Columns of the joint angles (relative to the robot's ``nominal_pose``) in the student
    observation (and in the teacher's, which starts with it)."""
    return slice(6, 6 + num_joints)


def joint_vel_columns(num_joints: int) -> slice:
    """Columns of the joint velocities (× ``JOINT_VEL_SCALE``) in the student observation (and
    in the teacher's, which starts with it)."""
    return slice(6 + num_joints, 6 + 2 * num_joints)


def prev_action_columns(num_joints: int) -> slice:
    """Columns of the previous action in the student observation (and in the teacher's, which
    starts with it)."""
    return slice(6 + 2 * num_joints, 6 + 3 * num_joints)


def privileged_columns(num_joints: int) -> dict[str, slice]:
    """Columns of each privileged block in the teacher observation (the student's first, then
    ``privileged_obs``'s order)."""
    sizes = {"slope": 1, "uphill": 3, "friction": 1, "velocity": 3, "height": 1, "scan": num_scan_points(), "factors": 3}
    out, start = {}, 6 + 3 * num_joints
    for name, n in sizes.items():
        out[name] = slice(start, start + n)
        start += n
    return out


def privileged_obs(
    rs: RobotState, slope_pct: torch.Tensor, friction: torch.Tensor, scan_z: torch.Tensor, factors: torch.Tensor
) -> torch.Tensor:
    """(n, 12 + S) privileged context.

    Args:
        slope_pct: (n,) grade of the tile, rising along world +x (%).
        friction: (n,) ground friction.
        scan_z: (n, S) ground heights at the scan points (m, world).
        factors: (n, 3) mass, Kp and Kd scale factors.
    """
    angle = torch.atan(slope_pct / 100.0)
    uphill_world = torch.zeros(len(angle), 3)
    uphill_world[:, 0] = torch.cos(angle)
    uphill_world[:, 2] = torch.sin(angle)
    uphill_body = torch.einsum("nji,nj->ni", rs.rot, uphill_world)
    lin_vel_body = torch.einsum("nji,nj->ni", rs.rot, rs.lin_vel)
    scan_rel = (rs.pos[:, 2:3] - scan_z.to(torch.float64)).float()
    return torch.cat(
        [angle[:, None], uphill_body, friction[:, None], lin_vel_body, rs.height_over_feet[:, None], scan_rel, factors],
        dim=-1,
    )


# ------------------------------------------------------------------ left-right mirror
# Mirroring the world in the trunk's sagittal (x-z) plane negates the y component of polar
# vectors (gravity, velocities, directions) and the x and z components of axial ones
# (angular velocity).
_POLAR = np.array([1.0, -1.0, 1.0])
_AXIAL = np.array([-1.0, 1.0, -1.0])


def student_mirror(joints: np.ndarray, signs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index ``p`` and signs ``s``, each (6 + 3J,): ``obs[..., p] * s`` is the student
    observation of the robot's mirror image, given the joints' mirror (``RobotSpec.mirror_joints``
    / ``mirror_signs``, each (J,))."""
    nj = len(joints)
    idx = [np.arange(3), 3 + np.arange(3)] + [6 + b * nj + joints for b in range(3)]
    sgn = [_POLAR, _AXIAL] + [signs] * 3
    return np.concatenate(idx), np.concatenate(sgn)


def privileged_mirror() -> tuple[np.ndarray, np.ndarray]:
    """Index and signs, each (12 + S,), of the privileged block's mirror (see ``student_mirror``):
    slope angle, friction, height and the mass/gain factors keep their values, the body-frame
    uphill direction and velocity flip y, and the height scan flips its y axis."""
    i, j = np.meshgrid(np.arange(SCAN_GRID), np.arange(SCAN_GRID), indexing="ij")
    scan = (i * SCAN_GRID + (SCAN_GRID - 1 - j)).ravel()  # scan_offsets: row-major, x then y
    blocks = [  # (indices within the block, signs), in privileged_obs's order
        (np.arange(1), np.ones(1)),  # slope angle
        (np.arange(3), _POLAR),  # uphill direction, body frame
        (np.arange(1), np.ones(1)),  # friction
        (np.arange(3), _POLAR),  # linear velocity, body frame
        (np.arange(1), np.ones(1)),  # height
        (scan, np.ones(len(scan))),  # height scan
        (np.arange(3), np.ones(3)),  # mass, Kp, Kd factors
    ]
    idx, sgn, start = [], [], 0
    for local, sign in blocks:
        idx.append(start + local)
        sgn.append(sign)
        start += len(local)
    return np.concatenate(idx), np.concatenate(sgn)


def num_scan_points() -> int:
    return SCAN_GRID * SCAN_GRID


def slope_deg(slope_pct: float) -> float:
    return math.degrees(math.atan(slope_pct / 100.0))
