"""A composite frozen teacher for distillation: the primary teacher acts, and a second
(fallback) teacher takes over for a while whenever the robot has stalled, the rule of
``selfright.policies.stall`` evaluated on the teacher observation, per env.

The flat teacher's misses are postures it lies or sits still in; a specialist trained with
large exploration noise from those postures gets the robot out of them (docs/training.md,
*What the flat failures are*). Distilling one student from the pair puts both into a single
sensor-only network: the labels are the fallback's actions in the states where it acts.
"""

from __future__ import annotations

import torch
from torch import nn

from selfright.policies.stall import StallSwitch


class StallFallbackTeacher(nn.Module):
    """``primary``'s action, or ``fallback``'s for ``hand_steps`` control steps after the robot
    has been still for ``stall_steps`` steps while tilted more than 30° or under ``bar_m``
    (``selfright.policies.stall``). Keeps per-env counters; rsl_rl's ``Distillation`` calls
    ``reset(dones)`` every step."""

    def __init__(self, primary: nn.Module, fallback: nn.Module, num_envs: int, num_joints: int,
                 stall_steps: int, hand_steps: int, bar_m: float):
        super().__init__()
        self.primary, self.fallback = primary, fallback
        self.switch = StallSwitch(stall_steps, hand_steps, bar_m, num_joints)
        self.slots = torch.arange(num_envs)

    def forward(self, obs) -> torch.Tensor:
        use = self.switch.step(obs["teacher"], self.slots).to(obs["teacher"].device)
        return torch.where(use[:, None], self.fallback(obs), self.primary(obs))

    def reset(self, dones: torch.Tensor | None = None, hidden_state=None) -> None:
        if dones is not None:
            self.switch.reset(dones.bool().cpu())

    def get_hidden_state(self):
        return None

    def detach_hidden_state(self, dones: torch.Tensor | None = None) -> None:
        pass
