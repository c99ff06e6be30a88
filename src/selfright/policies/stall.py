"""The stall hand-over rule: per env slot, when has the robot lain still long enough for a
second policy to take over, and for how long does it act. Shared by the evaluation-time
``selfright.policies.variants.Fallback`` and the distillation teacher
``selfright.train.fallback_teacher.StallFallbackTeacher``.

Stalled = tilted more than ``TILT_DEG`` from upright (the IMU's projected gravity), or, with a
bar, upright with the trunk under it (the teacher observation's height, a privileged
reading); with the joint velocities' norm under ``JOINT_SPEED_RAD_S`` and the trunk's angular
speed under ``ANG_SPEED_RAD_S``; for ``stall_steps`` control steps in a row. The second
policy then acts for ``hand_steps`` steps, after which the count starts again.
"""

from __future__ import annotations

import math

import torch

from selfright.env.observations import JOINT_VEL_SCALE, joint_vel_columns, teacher_height_column

TILT_DEG = 30.0
JOINT_SPEED_RAD_S = 1.0
ANG_SPEED_RAD_S = 0.5


class StallSwitch:
    """Per-slot counters of the hand-over rule. Slots are indices ``0..``; the counters grow
    to the largest slot seen."""

    def __init__(self, stall_steps: int, hand_steps: int, bar_m: float | None = None, num_joints: int = 12):
        self.stall_steps, self.hand_steps, self.bar_m = stall_steps, hand_steps, bar_m
        self.qd = joint_vel_columns(num_joints)
        self.height = teacher_height_column(num_joints)
        self._still = torch.zeros(0, dtype=torch.long)
        self._left = torch.zeros(0, dtype=torch.long)

    def _grow(self, n: int) -> None:
        if n > len(self._still):
            pad = torch.zeros(n - len(self._still), dtype=torch.long)
            self._still, self._left = torch.cat([self._still, pad]), torch.cat([self._left, pad])

    def reset(self, slots: torch.Tensor) -> None:
        """Zero the counters of ``slots`` (indices, or a bool mask over all slots)."""
        slots = torch.as_tensor(slots)
        if slots.dtype == torch.bool:
            slots = slots.nonzero().flatten()
        if len(slots):
            self._grow(int(slots.max()) + 1)
            self._still = self._still.index_fill(0, slots.cpu(), 0)  # out of place: rollouts may run in inference mode
            self._left = self._left.index_fill(0, slots.cpu(), 0)

    def step(self, x: torch.Tensor, slots: torch.Tensor) -> torch.Tensor:
        """One control step of ``slots`` (k,) with observations ``x`` (k, D): student columns
        first, the teacher's if ``bar_m`` is set. Returns (k,) bool: the second policy acts."""
        slots = torch.as_tensor(slots).cpu()
        self._grow(int(slots.max()) + 1 if len(slots) else 0)
        x = x.detach().cpu()
        upright = -x[:, 2] >= math.cos(math.radians(TILT_DEG))
        if self.bar_m is not None:
            upright &= x[:, self.height] >= self.bar_m  # upright but low is a stall too
        still = (x[:, self.qd].norm(dim=1) / JOINT_VEL_SCALE < JOINT_SPEED_RAD_S) & (x[:, 3:6].norm(dim=1) < ANG_SPEED_RAD_S)
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
