"""A composite frozen teacher for distillation: the primary teacher acts where the trunk is
upright within ``--train.distillation.fallback-tilt-deg``, a second (fallback) teacher wherever
it is tilted more (``selfright.train.tilt.TiltSwitch``, evaluated per env on the teacher
observation).

The flat teacher's misses are postures it lies or sits still in; a specialist trained with
large exploration noise from those postures gets the robot out of them (docs/training.md,
*`flat` (student, one frame)*). Distilling one student from the pair puts both into a single sensor-only
network: the labels are the fallback's actions in the states where it acts. The rule is a
function of the current state, which a one-frame student sees.

The two teachers may have been trained around different fixed action references (``stand`` /
``tall``): the fallback's actions are then shifted into the primary's (the student's) units and
the previous action it observes is shifted back, as ``selfright.policies.reference`` does at
evaluation time.
"""

from __future__ import annotations

import torch
from torch import nn

from selfright.policies.reference import ReferenceShift
from selfright.train.tilt import TiltSwitch


class FallbackTeacher(nn.Module):
    """``primary``'s action, or ``fallback``'s where ``switch`` says the trunk is tilted over.
    rsl_rl's ``Distillation`` calls ``reset(dones)`` every step.

    Args:
        fallback_offset: (J,) (fallback's reference pose − primary's) / action scale, in action
            units, when the two differ; None when they are the same.
    """

    def __init__(
        self, primary: nn.Module, fallback: nn.Module, num_envs: int, switch: TiltSwitch,
        fallback_offset: torch.Tensor | None = None,
    ):
        super().__init__()
        self.primary, self.fallback, self.switch = primary, fallback, switch
        self.shift = ReferenceShift(fallback_offset, num_envs)

    def forward(self, obs) -> torch.Tensor:
        x = obs["teacher"]
        use = self.switch.step(x).to(x.device)
        return torch.where(use[:, None], self._fallback_action(obs), self.primary(obs))

    def _fallback_action(self, obs) -> torch.Tensor:
        if self.shift.offset is None:
            return self.fallback(obs)
        shifted = obs.clone()
        shifted["teacher"] = self.shift.obs(obs["teacher"])
        self.shift.stepped()
        return self.shift.action(self.fallback(shifted))

    def reset(self, dones: torch.Tensor | None = None, hidden_state=None) -> None:
        if dones is not None:
            self.shift.reset(dones.bool().cpu())

    def get_hidden_state(self):
        return None

    def detach_hidden_state(self, dones: torch.Tensor | None = None) -> None:
        pass
