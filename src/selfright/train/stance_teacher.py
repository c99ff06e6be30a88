"""A frozen teacher that labels a fixed tall stance: a base student's own actions, blended to
the stance once the trunk has settled upright.

The students get up and then stand low, feet spread fore and aft of the hips; blending their
labels to a fixed stance (feet under the hips, knees at their limit) once the trunk has been
upright (projected gravity within ``tilt_deg`` of down) for a delay makes them stand taller
over their feet (docs/training.md, *Choices that are not in the seed*). The delay is a count
of steps the student does not observe; what it learns is the expected label given its
observation.

Without a stance (``--teacher STUDENT`` and no ``stance_ramp_s``) the labels are the base
student's own actions: a copy of the student. The labelling student always reads the *exact*
student observation (group ``LABEL_GROUP``).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from selfright.config import ActionConfig
from selfright.policies.actor import ActorMLP
from selfright.train.tilt import TiltSwitch


def upright_count(count: torch.Tensor, upright: torch.Tensor) -> torch.Tensor:
    """(k,) control steps each slot has been upright, after this step: ``count`` + 1 where
    ``upright`` (k,) bool, 0 where it is not."""
    return torch.where(upright.to(count.device), count + 1.0, torch.zeros((), dtype=count.dtype))


def pose_blend(actions: torch.Tensor, count: torch.Tensor, delay_steps: int, ramp_steps: int,
               target: torch.Tensor, weight: float = 1.0) -> torch.Tensor:
    """``actions`` (k, J) blended towards ``target`` (J,) by w = ``weight`` · clamp((count − delay)
    / ramp, 0, 1): the slot's own action until the trunk has been upright ``delay_steps`` steps,
    then, after ``ramp_steps`` more, the target (``weight`` 1) or a share ``weight`` of the way to
    it (the policy's own corrections kept)."""
    w = weight * ((count - delay_steps) / ramp_steps).clamp(0.0, 1.0).to(actions.device, actions.dtype)[:, None]
    return (1.0 - w) * actions + w * target.to(actions.device, actions.dtype)


def stance_action(robot, action: ActionConfig, leg: tuple[float, float, float]) -> np.ndarray:
    """(J,) the action, under the action mapping ``action``, whose targets are the hip, thigh and
    knee angles ``leg`` (rad) on every leg of ``robot``. Needs a fixed action reference."""
    ref = robot.reference_pose(action.reference)
    if ref is None:
        raise ValueError("a fixed pose needs a fixed action reference (stand / tall), not 'current'")
    q = np.tile(np.asarray(leg, dtype=np.float64), len(robot.joint_names) // 3)
    return (q - ref) / action.scale_rad


class StanceTeacher(nn.Module):
    """``base``'s actions on the ``group`` observation, blended over ``ramp_steps`` to ``target``
    (J,) (action units; a share ``weight`` of the way) once the trunk has been upright for
    ``delay_steps`` control steps; handed straight back when it tilts over. ``target`` None: no
    stance, the labels are ``base``'s actions. rsl_rl's ``Distillation`` calls ``reset(dones)``
    every step."""

    def __init__(self, base: ActorMLP, group: str, num_envs: int, tilt_deg: float, delay_steps: int,
                 ramp_steps: int, target: torch.Tensor | None, weight: float = 1.0):
        super().__init__()
        if target is not None and (ramp_steps < 1 or delay_steps < 0):
            raise ValueError(f"the stance needs a ramp of at least one step and a delay ≥ 0, got {ramp_steps}, {delay_steps}")
        if not 0.0 < weight <= 1.0:
            raise ValueError(f"the stance weight is in (0, 1], got {weight}")
        self.base, self.group = base, group
        self.tilted = TiltSwitch(tilt_deg)
        self.delay, self.ramp, self.weight = int(delay_steps), int(ramp_steps), float(weight)
        self.register_buffer("target", None if target is None else torch.as_tensor(target, dtype=torch.float32))
        self.count = torch.zeros(num_envs)
        """Control steps each env's trunk has been upright (CPU)."""

    @torch.no_grad()
    def forward(self, obs) -> torch.Tensor:
        x = obs["teacher"]  # the current frame's student columns come first (projected gravity at 0:3)
        self.count = upright_count(self.count, ~self.tilted.step(x))
        labels = self.base(obs[self.group])
        if self.target is not None:
            labels = pose_blend(labels, self.count, self.delay, self.ramp, self.target, weight=self.weight)
        return labels

    def reset(self, dones: torch.Tensor | None = None, hidden_state=None) -> None:
        if dones is not None:
            # out of place: the count may have been made under rsl_rl's inference mode
            self.count = self.count.masked_fill(dones.reshape(-1).bool().cpu(), 0.0)

    def get_hidden_state(self):
        return None

    def detach_hidden_state(self, dones: torch.Tensor | None = None) -> None:
        pass
