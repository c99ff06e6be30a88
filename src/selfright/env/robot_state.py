"""Decoding batched MuJoCo states into the quantities the goal set, observations and
rewards read (torch, float32 unless stated)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from selfright.sim.batch import StateLayout
from selfright.sim.scene import SensorLayout


@dataclass
class RobotState:
    """Quantities of n envs at the end of a control step."""

    pos: torch.Tensor
    """(n, 3) trunk position, world frame (m), float64."""
    rot: torch.Tensor
    """(n, 3, 3) trunk rotation, body → world."""
    lin_vel: torch.Tensor
    """(n, 3) trunk linear velocity, world frame (m/s)."""
    ang_vel: torch.Tensor
    """(n, 3) trunk angular velocity, body frame (rad/s)."""
    q: torch.Tensor
    """(n, J) joint angles (rad)."""
    qd: torch.Tensor
    """(n, J) joint velocities (rad/s)."""
    torque: torch.Tensor
    """(n, J) motor torques of the last physics step (N·m)."""
    feet_contact: torch.Tensor
    """(n, F) bool, foot touches the ground."""
    body_contacts: torch.Tensor
    """(n,) number of non-foot bodies touching the ground."""
    ground_z: torch.Tensor
    """(n,) ground height under the trunk (m)."""
    feet_pos: torch.Tensor
    """(n, F, 3) world positions of the foot spheres' centres (m), float64. Read by MuJoCo
    sensors, which take them at the start of the last physics step of the control step (5 ms
    before ``pos``; millimetres apart at most)."""
    foot_radius: torch.Tensor
    """(F,) radius of each foot sphere (m), float64."""

    @property
    def height_over_terrain(self) -> torch.Tensor:
        """(n,) trunk origin's height above the ground beneath it (m): the goal set's height
        with ``GoalConfig.height_ref = "terrain"`` (for comparison)."""
        return (self.pos[:, 2] - self.ground_z.to(torch.float64)).float()

    @property
    def height_over_feet(self) -> torch.Tensor:
        """(n,) trunk origin's height above the mean of the four feet's lowest points (foot
        centre minus radius), along gravity (world −z) (m): the body height of the goal set
        (``GoalConfig.height_ref = "feet"``), the reward, the teacher and the traces."""
        lowest = self.feet_pos[:, :, 2].to(torch.float64) - self.foot_radius.to(torch.float64)
        return (self.pos[:, 2] - lowest.mean(dim=1)).float()

    @property
    def projected_gravity(self) -> torch.Tensor:
        """(n, 3) unit gravity direction in the body frame (what an IMU's tilt gives)."""
        return -self.rot[:, 2, :]

    @property
    def up_z(self) -> torch.Tensor:
        """(n,) cos of the angle between the trunk up axis and world z."""
        return self.rot[:, 2, 2]

    @property
    def roll(self) -> torch.Tensor:
        return torch.atan2(self.rot[:, 2, 1], self.rot[:, 2, 2])

    @property
    def pitch(self) -> torch.Tensor:
        return torch.asin(torch.clamp(-self.rot[:, 2, 0], -1.0, 1.0))


def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
    """(n, 4) quaternions (w, x, y, z) -> (n, 3, 3) rotation matrices (numpy: fewer, cheaper ops in the hot path)."""
    q = quat / np.maximum(np.linalg.norm(quat, axis=-1, keepdims=True), 1e-9)
    w, x, y, z = q.T
    m = np.empty((len(q), 9), dtype=quat.dtype)
    m[:, 0] = 1 - 2 * (y * y + z * z)
    m[:, 1] = 2 * (x * y - w * z)
    m[:, 2] = 2 * (x * z + w * y)
    m[:, 3] = 2 * (x * y + w * z)
    m[:, 4] = 1 - 2 * (x * x + z * z)
    m[:, 5] = 2 * (y * z - w * x)
    m[:, 6] = 2 * (x * z - w * y)
    m[:, 7] = 2 * (y * z + w * x)
    m[:, 8] = 1 - 2 * (x * x + y * y)
    return m.reshape(-1, 3, 3)


def decode(
    state: np.ndarray, sens: np.ndarray, ground_z: np.ndarray, sl: StateLayout, so: SensorLayout, foot_radius: np.ndarray
) -> RobotState:
    """Build a RobotState from (n, nstate) states, (n, nsensordata) sensor readings, (n,)
    ground heights under the trunks and the (F,) foot radii (m)."""
    s32 = torch.from_numpy(state.astype(np.float32))  # one conversion; the fields are views
    return RobotState(
        pos=torch.from_numpy(np.ascontiguousarray(state[:, sl.pos])),
        rot=torch.from_numpy(quat_to_matrix(state[:, sl.quat]).astype(np.float32)),
        lin_vel=s32[:, sl.lin_vel],
        ang_vel=s32[:, sl.ang_vel],
        q=s32[:, sl.qpos_joints],
        qd=s32[:, sl.qvel_joints],
        torque=torch.from_numpy(sens[:, so.actuator_force].astype(np.float32)),
        feet_contact=torch.from_numpy(sens[:, so.foot_contact] > 0),
        body_contacts=torch.from_numpy((sens[:, so.body_contact] > 0).sum(axis=1).astype(np.float32)),
        ground_z=torch.from_numpy(np.asarray(ground_z, dtype=np.float64)),
        feet_pos=torch.from_numpy(np.ascontiguousarray(sens[:, so.foot_pos]).reshape(len(sens), -1, 3)),
        foot_radius=torch.from_numpy(np.asarray(foot_radius, dtype=np.float64)),
    )
