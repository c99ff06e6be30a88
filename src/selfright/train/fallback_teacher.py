"""A composite frozen teacher for distillation: the primary teacher acts, and a second
(fallback) teacher where a hand-over rule of ``selfright.policies.stall`` says so, per env,
evaluated on the teacher observation: for a while after the robot has stalled
(``StallSwitch``), or whenever it is tilted over (``TiltSwitch``).

The flat teacher's misses are postures it lies or sits still in; a specialist trained with
large exploration noise from those postures gets the robot out of them (docs/training.md,
*What the flat failures are*). Distilling one student from the pair puts both into a single
sensor-only network: the labels are the fallback's actions in the states where it acts. With
the tilt rule the label is a function of the current state, which a one-frame student sees.
"""

from __future__ import annotations

import torch
from torch import nn

from selfright.policies.stall import StallSwitch, TiltSwitch


class FallbackTeacher(nn.Module):
    """``primary``'s action, or ``fallback``'s where ``switch`` hands over. Keeps the switch's
    per-env state; rsl_rl's ``Distillation`` calls ``reset(dones)`` every step."""

    def __init__(self, primary: nn.Module, fallback: nn.Module, num_envs: int, switch: StallSwitch | TiltSwitch):
        super().__init__()
        self.primary, self.fallback, self.switch = primary, fallback, switch
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
