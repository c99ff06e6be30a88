"""Trunk height from proprioception: what a robot with only an IMU and joint encoders knows
about how high its trunk stands.

The feet's positions in the trunk frame follow from the joint angles (forward kinematics of
the robot's own MJCF); the IMU's projected gravity says which way is down. On level ground
the lowest foot touches it, so the trunk stands as high above the ground as that foot's
bottom lies below the trunk origin, measured along gravity. This is the estimate legged
robots' state estimators make from leg kinematics; it is exact on a plane with a foot down,
and off by the bump or trough under the trunk on rough ground.
"""

from __future__ import annotations

import mujoco
import numpy as np
import torch

from selfright.robots.spec import RobotSpec


class KinematicHeight:
    """``height(gravity, q)``: (k,) trunk heights (m) above the lowest foot's bottom, from the
    projected gravity (k, 3) (a unit vector in the trunk frame, pointing down) and the joint
    angles (k, J) (rad, in ``robot.joint_names`` order)."""

    def __init__(self, robot: RobotSpec):
        self.model = mujoco.MjModel.from_xml_string(robot.mjcf(1.0, 0.0))
        self.data = mujoco.MjData(self.model)
        geom = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in robot.foot_geoms]
        self.feet = np.asarray(geom)
        self.foot_radius = self.model.geom_size[self.feet, 0].copy()
        joints = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in robot.joint_names]
        self.qadr = self.model.jnt_qposadr[joints]
        self.trunk = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, robot.trunk_body)
        free = int(np.flatnonzero(self.model.jnt_type == mujoco.mjtJoint.mjJNT_FREE)[0])
        self.qpos = self.model.qpos0.copy()
        self.qpos[self.model.jnt_qposadr[free] + 3:self.model.jnt_qposadr[free] + 7] = (1.0, 0.0, 0.0, 0.0)

    def feet_in_trunk_frame(self, q: np.ndarray) -> np.ndarray:
        """(k, F, 3) foot-centre positions relative to the trunk origin, in the trunk frame (m)."""
        q = np.atleast_2d(np.asarray(q, dtype=np.float64))
        out = np.empty((len(q), len(self.feet), 3))
        d = self.data
        d.qpos[:] = self.qpos  # the trunk unrotated: world axes = trunk axes
        for i, row in enumerate(q):
            d.qpos[self.qadr] = row
            mujoco.mj_kinematics(self.model, d)
            out[i] = d.geom_xpos[self.feet] - d.xpos[self.trunk]
        return out

    def __call__(self, gravity: torch.Tensor, q: torch.Tensor) -> torch.Tensor:
        feet = torch.as_tensor(self.feet_in_trunk_frame(q.detach().cpu().numpy()), dtype=torch.float32)
        down = torch.nn.functional.normalize(gravity.detach().cpu().float(), dim=1)
        depth = (feet @ down.unsqueeze(2)).squeeze(2) + torch.as_tensor(self.foot_radius, dtype=torch.float32)
        return depth.max(dim=1).values

    def level(self, q: np.ndarray) -> np.ndarray:
        """(k,) trunk heights (m) over the feet of the poses ``q`` (k, J) with the trunk level:
        ``height`` with gravity straight down the trunk's z axis."""
        q = torch.as_tensor(np.atleast_2d(np.asarray(q)))
        return self(torch.tensor([[0.0, 0.0, -1.0]]).expand(len(q), 3), q).numpy()
