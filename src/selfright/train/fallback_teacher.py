"""A composite frozen teacher for distillation: the primary teacher acts, and a second
(fallback) teacher takes over for a while whenever the robot has stalled, the rule of
``selfright.policies.variants.Fallback`` evaluated on the teacher observation, per env.

The flat teacher's misses are postures it lies or sits still in; a specialist trained with
large exploration noise from those postures gets the robot out of them (docs/training.md,
*What the flat failures are*). Distilling one student from the pair puts both into a single
sensor-only network: the labels are the fallback's actions in the states where it acts.
"""

from __future__ import annotations

import math

import torch
from torch import nn

from selfright.env.observations import JOINT_VEL_SCALE, teacher_height_column


class StallFallbackTeacher(nn.Module):
    """``primary``'s action, or ``fallback``'s for ``hand_steps`` control steps after the robot
    has been still for ``stall_steps`` steps while tilted more than 30° or under ``bar_m``.
    Keeps per-env counters; rsl_rl's ``Distillation`` calls ``reset(dones)`` every step."""

    def __init__(self, primary: nn.Module, fallback: nn.Module, num_envs: int, num_joints: int,
                 stall_steps: int, hand_steps: int, bar_m: float):
        super().__init__()
        self.primary, self.fallback = primary, fallback
        self.stall_steps, self.hand_steps, self.bar_m = stall_steps, hand_steps, bar_m
        self.qd = slice(6 + num_joints, 6 + 2 * num_joints)
        self.height = teacher_height_column(num_joints)
        self._still = torch.zeros(num_envs, dtype=torch.long)
        self._left = torch.zeros(num_envs, dtype=torch.long)

    def forward(self, obs) -> torch.Tensor:
        x = obs["teacher"]
        dev = x.device
        still_cnt, left = self._still.to(dev), self._left.to(dev)
        upright = (-x[:, 2] >= math.cos(math.radians(30.0))) & (x[:, self.height] >= self.bar_m)
        still = (x[:, self.qd].norm(dim=1) / JOINT_VEL_SCALE < 1.0) & (x[:, 3:6].norm(dim=1) < 0.5)
        handing = left > 0
        left = torch.where(handing, left - 1, left)
        still_cnt = torch.where(~handing & still & ~upright, still_cnt + 1, torch.zeros_like(still_cnt))
        start = still_cnt >= self.stall_steps
        left = torch.where(start, torch.full_like(left, self.hand_steps - 1), left)
        still_cnt = torch.where(start, torch.zeros_like(still_cnt), still_cnt)
        self._still, self._left = still_cnt, left
        use = handing | start
        return torch.where(use[:, None], self.fallback(obs), self.primary(obs))

    def reset(self, dones: torch.Tensor | None = None, hidden_state=None) -> None:
        if dones is None:
            return
        d = dones.bool().to(self._still.device)  # out of place: rollouts run in inference mode
        self._still = torch.where(d, torch.zeros_like(self._still), self._still)
        self._left = torch.where(d, torch.zeros_like(self._left), self._left)

    def get_hidden_state(self):
        return None

    def detach_hidden_state(self, dones: torch.Tensor | None = None) -> None:
        pass
