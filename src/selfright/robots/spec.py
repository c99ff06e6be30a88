"""Robot specification: everything the benchmark needs to know about a robot, by name."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np


@dataclass(frozen=True, kw_only=True)
class RobotSpec:
    """A legged robot as the benchmark sees it.

    The MJCF returned by ``mjcf`` must contain: a free-floating body named ``trunk_body``,
    actuators in the order of ``joint_names`` (PD position servos), one collision geom per
    foot named as in ``foot_geoms``, and a default class ``robot`` for all collision geoms.
    """

    name: str
    """Registry name."""
    trunk_body: str
    """Name of the floating base body."""
    joint_names: tuple[str, ...]
    """Actuated joints, in action order."""
    foot_geoms: tuple[str, ...]
    """Collision geoms of the feet."""
    collision_geoms: tuple[str, ...]
    """One geom per non-foot body (its foot-free collision shape); ground contacts of these
    count as collisions. Geoms, not bodies: a foot sphere sits in its calf body, and a body
    sensor would count every foot contact as a calf collision."""
    joint_low: np.ndarray
    """Lower joint limits (rad), shape (num_joints,)."""
    joint_high: np.ndarray
    """Upper joint limits (rad), shape (num_joints,)."""
    nominal_pose: np.ndarray
    """Nominal standing joint angles (rad), shape (num_joints,)."""
    stand_pose: np.ndarray
    """Standing joint angles whose trunk height clears the goal-set bar (rad)."""
    leg_length_m: float
    """Fully extended leg length, hip axis to foot centre (m)."""
    stand_height_m: float
    """Trunk height of ``stand_pose`` on flat ground (m): the reward's target height z*. Must
    exceed the goal-set bar (``GoalConfig.height_fraction`` × ``leg_length_m``)."""
    body_length_m: float
    """Overall body length (m)."""
    torque_limit: float
    """Motor torque limit (N·m)."""
    rated_joint_speed: float | None = None
    """Published maximum joint speed of the motors (rad/s): the no-load speed of
    ``RobotConfig.motor = "dcmotor"``, the benchmark's default (``ideal`` servos give full torque
    at any speed). None: not published."""
    mjcf: Callable[..., str]
    """``mjcf(kp, kd, stop_timeconst_s=..., motor="ideal")`` -> MJCF text of the robot alone (a
    ``<mujoco>`` document), PD gains ``kp``, ``kd``, hard joint stops of that ``solreflimit``
    time constant (s; ``RobotConfig.joint_stop_timeconst_s``) and motor model ``motor``
    (``RobotConfig.motor``; a robot without a given model raises ``ValueError``); with
    ``motor_speed=`` (rad/s; ``RobotConfig.motor_speed_rad_s``) the DC motor's no-load speed."""
    leg_roots_m: np.ndarray | None = None
    """(F, 3) each leg's root in the trunk frame (m), ordered like ``foot_geoms``: the thigh
    joint's origin at zero abduction, the point a vertical leg's foot stands under (the
    ``feet_under_hips`` reward term). None: not given."""
    tall_pose: np.ndarray | None = None
    """Standing joint angles with straighter legs than ``stand_pose`` (rad), the action
    reference of ``ActionConfig.reference="tall"``; None: the robot has none."""
    mirror_joints: np.ndarray | None = None
    """Left-right mirror of the joints, (num_joints,) ints: joint ``j`` of the robot's mirror
    image in its sagittal (x-z) plane is joint ``mirror_joints[j]`` of the robot, with sign
    ``mirror_signs[j]`` (angles, velocities and targets alike). None: not mirror-symmetric."""
    mirror_signs: np.ndarray | None = None
    """(num_joints,) ±1 that go with ``mirror_joints`` (−1 for joints about the x or z axis)."""

    @property
    def num_joints(self) -> int:
        return len(self.joint_names)

    def reference_pose(self, reference: str) -> np.ndarray | None:
        """(num_joints,) joint angles that action 0 means under ``ActionConfig.reference``
        (``stand`` or ``tall``); None for ``current`` (the angles at each control step)."""
        if reference == "current":
            return None
        pose = {"stand": self.stand_pose, "tall": self.tall_pose}.get(reference)
        if pose is None:
            raise ValueError(f"robot {self.name!r} has no {reference!r} pose; use --action-reference stand or current")
        return pose
