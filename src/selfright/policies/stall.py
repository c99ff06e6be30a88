"""Hand-over rules: per env slot, does a second policy act instead of the first. Their users
(the distillation teachers of ``selfright.train``) call ``reset(slots)`` at an episode's start
and ``step(x, slots)`` every control step.

``TiltSwitch``: the second acts whenever the robot is tilted more than ``tilt_deg`` from
upright (the IMU's projected gravity). A function of the current observation alone, so a
one-frame student can learn the composite it labels.

``ScanSwitch``: the second acts where the teacher's height scan reads rough ground.

``StallSwitch``: the second takes over once the robot has lain still long enough, for a
while. Stalled = tilted more than ``TILT_DEG`` from upright (the IMU's projected gravity), or, with a
bar, upright with the trunk under it (the teacher observation's height, a privileged
reading, or with ``robot`` the height its leg kinematics give: ``KinematicHeight``, sensors
only); with the joint velocities' norm under ``JOINT_SPEED_RAD_S`` and the trunk's angular
speed under ``ANG_SPEED_RAD_S``; for ``stall_steps`` control steps in a row. The second
policy then acts for ``hand_steps`` steps, after which the count starts again.
"""

from __future__ import annotations

import math

import torch

from selfright.env.observations import (
    JOINT_VEL_SCALE, joint_pos_columns, joint_vel_columns, privileged_columns, teacher_height_column,
)
from selfright.policies.slots import grown, slot_index
from selfright.robots.kinematics import KinematicHeight
from selfright.robots.spec import RobotSpec

TILT_DEG = 30.0
JOINT_SPEED_RAD_S = 1.0
ANG_SPEED_RAD_S = 0.5


class TiltSwitch:
    """The second policy acts while the trunk's up axis is more than ``tilt_deg`` from world z.

    With ``release_deg`` (> ``tilt_deg``) the rule has hysteresis: once a slot's trunk has come
    within ``tilt_deg`` of upright, the first policy keeps acting until the tilt passes
    ``release_deg``, so a robot that rolls through upright is not handed straight back to the
    second. Each slot's mode is kept from step to step; ``reset`` clears it."""

    needs_teacher = False

    def __init__(self, tilt_deg: float, release_deg: float | None = None):
        if not 0.0 < tilt_deg < 180.0:
            raise ValueError(f"tilt_deg must lie in (0, 180), got {tilt_deg}")
        if release_deg is not None and not tilt_deg < release_deg < 180.0:
            raise ValueError(f"release_deg must lie in (tilt_deg, 180) = ({tilt_deg:g}, 180), got {release_deg}")
        self.tilt_deg, self.release_deg = tilt_deg, release_deg
        self.when = f"tilted over {tilt_deg:g} deg" + (f" (until upright, then over {release_deg:g} deg)" if release_deg else "")
        self._cos = math.cos(math.radians(tilt_deg))
        self._cos_release = math.cos(math.radians(release_deg)) if release_deg is not None else None
        self._caught = torch.zeros(0, dtype=torch.bool)

    def reset(self, slots: torch.Tensor) -> None:
        """Clear the hysteresis mode of ``slots`` (indices, or a bool mask over all slots)."""
        if self._cos_release is None:
            return
        t = slot_index(slots)
        self._caught = grown(self._caught, t, False).index_fill(0, t, False)

    def step(self, x: torch.Tensor, slots: torch.Tensor) -> torch.Tensor:
        """(k,) bool for observations ``x`` (k, D), student columns first: the second policy acts."""
        up_z = -x[:, 2].detach().cpu()
        if self._cos_release is None:
            return up_z < self._cos
        t = slot_index(slots)
        self._caught = grown(self._caught, t, False)
        caught = (up_z >= self._cos) | (self._caught[t] & (up_z >= self._cos_release))
        self._caught = self._caught.index_copy(0, t, caught)
        return ~caught


class ScanSwitch:
    """The second policy acts where the ground under the trunk is rough: the standard deviation
    of the teacher observation's height scan (``SCAN_GRID``² points over 0.6 m, trunk height
    minus ground height) exceeds ``std_m``. A privileged reading, for composite teachers on
    level rough ground: on the ``rough`` grid the scan's spread is about 0.02 / 0.037 / 0.055 m
    (medians) at levels 4 / 8 / 12, so 0.027 m separates level 4 from the rougher two. A slope
    spreads the scan as well (about 0.06 m at 20°), so it is no rule for inclines."""

    needs_teacher = True

    def __init__(self, std_m: float, num_joints: int = 12):
        if std_m <= 0:
            raise ValueError(f"std_m must be positive, got {std_m}")
        self.std_m = std_m
        self.scan = privileged_columns(num_joints)["scan"]
        self.when = f"the height scan spreads over {std_m:g} m"

    def reset(self, slots: torch.Tensor) -> None:
        """Nothing to reset: the rule keeps no state."""

    def step(self, x: torch.Tensor, slots: torch.Tensor) -> torch.Tensor:
        """(k,) bool for teacher observations ``x`` (k, D): the second policy acts."""
        return (x[:, self.scan].std(dim=1) > self.std_m).cpu()


class StallSwitch:
    """Per-slot counters of the hand-over rule. Slots are indices ``0..``; the counters grow
    to the largest slot seen."""

    def __init__(
        self, stall_steps: int, hand_steps: int, bar_m: float | None = None, num_joints: int = 12,
        robot: RobotSpec | None = None,
    ):
        """``robot``: with ``bar_m``, read the trunk height from the student observation (its
        projected gravity and joint angles, through the robot's leg kinematics) instead of the
        teacher observation's privileged height."""
        self.needs_teacher = bar_m is not None and robot is None
        self.when = "stalled"
        self.stall_steps, self.hand_steps, self.bar_m = stall_steps, hand_steps, bar_m
        self._tilted = TiltSwitch(TILT_DEG)
        self.qd = joint_vel_columns(num_joints)
        self.height = teacher_height_column(num_joints)
        self._kinematic = KinematicHeight(robot) if bar_m is not None and robot is not None else None
        self._nominal = torch.as_tensor(robot.nominal_pose, dtype=torch.float32) if robot is not None else None
        self._still = torch.zeros(0, dtype=torch.long)
        self._left = torch.zeros(0, dtype=torch.long)

    def _slots(self, slots: torch.Tensor) -> torch.Tensor:
        """``slots`` as an index tensor, the counters grown to hold every one of them."""
        t = slot_index(slots)
        self._still, self._left = grown(self._still, t), grown(self._left, t)
        return t

    def reset(self, slots: torch.Tensor) -> None:
        """Zero the counters of ``slots`` (indices, or a bool mask over all slots)."""
        t = self._slots(slots)
        self._still = self._still.index_fill(0, t, 0)  # out of place: rollouts may run in inference mode
        self._left = self._left.index_fill(0, t, 0)

    def step(self, x: torch.Tensor, slots: torch.Tensor) -> torch.Tensor:
        """One control step of ``slots`` (k,) with observations ``x`` (k, D): student columns
        first, the teacher's if ``bar_m`` is set. Returns (k,) bool: the second policy acts."""
        slots = self._slots(slots)
        x = x.detach().cpu()
        upright = ~self._tilted.step(x, slots)
        still = (x[:, self.qd].norm(dim=1) / JOINT_VEL_SCALE < JOINT_SPEED_RAD_S) & (x[:, 3:6].norm(dim=1) < ANG_SPEED_RAD_S)
        if self.bar_m is not None:  # upright but low is a stall too; only a still robot's height counts
            check = upright & still
            if check.any():
                upright[check] = self._trunk_height(x[check]) >= self.bar_m
        count, left = self._still[slots], self._left[slots]
        handing = left > 0
        left = torch.where(handing, left - 1, left)
        count = torch.where(~handing & still & ~upright, count + 1, torch.zeros_like(count))
        start = count >= self.stall_steps
        left = torch.where(start, torch.full_like(left, self.hand_steps - 1), left)
        count = torch.where(start, torch.zeros_like(count), count)
        self._still = self._still.index_copy(0, slots, count)
        self._left = self._left.index_copy(0, slots, left)
        return handing | start

    def _trunk_height(self, x: torch.Tensor) -> torch.Tensor:
        """(k,) trunk height (m): the teacher observation's, or the leg kinematics' estimate."""
        if self._kinematic is None:
            return x[:, self.height]
        q = x[:, joint_pos_columns(len(self._nominal))] + self._nominal
        return self._kinematic(x[:, 0:3], q)


def hand_over_rule(
    tilt_deg: float, stall_s: float, hand_s: float, control_dt_s: float, bar_m: float | None = None, num_joints: int = 12,
    release_deg: float | None = None,
) -> TiltSwitch | StallSwitch:
    """The rule a user picked: ``TiltSwitch(tilt_deg, release_deg)`` if ``tilt_deg`` > 0, else a
    ``StallSwitch`` that hands over after ``stall_s`` of stillness for ``hand_s`` (seconds,
    converted to control steps of ``control_dt_s``)."""
    if tilt_deg > 0:
        return TiltSwitch(tilt_deg, release_deg)
    return StallSwitch(round(stall_s / control_dt_s), round(hand_s / control_dt_s), bar_m, num_joints)
