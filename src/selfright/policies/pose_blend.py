"""The blend towards a fixed pose once upright, for the distillation teacher
``selfright.train.stance_teacher.StanceTeacher``: per slot, a count of control steps the trunk
has been upright, and a weight that ramps the actions to the pose once the count passes a delay."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch

from selfright.config import ActionConfig


def upright_count(count: torch.Tensor, upright: torch.Tensor) -> torch.Tensor:
    """(k,) control steps each slot has been upright, after this step: ``count`` + 1 where
    ``upright`` (k,) bool, 0 where it is not."""
    return torch.where(upright.to(count.device), count + 1.0, torch.zeros((), dtype=count.dtype))


def blend_weight(weight: float) -> float:
    """``weight`` as a float, checked to lie in (0, 1]: how far a pose blend goes (1 = all the way
    to the pose). The blend's users check it once, when they are built."""
    if not 0.0 < weight <= 1.0:
        raise ValueError(f"the pose blend weight is in (0, 1], got {weight}")
    return float(weight)


def pose_blend(actions: torch.Tensor, count: torch.Tensor, delay_steps: int, ramp_steps: int,
               target: torch.Tensor, columns: list[int] | None = None, weight: float = 1.0) -> torch.Tensor:
    """``actions`` (k, J) with ``columns`` (all when None) blended towards ``target`` (len(columns),)
    by w = ``weight`` · clamp((count − delay) / ramp, 0, 1): the slot's own action until the trunk
    has been upright ``delay_steps`` steps, then, after ``ramp_steps`` more, the target (``weight``
    1) or a share ``weight`` of the way to it (the policy's own corrections kept)."""
    w = weight * ((count - delay_steps) / ramp_steps).clamp(0.0, 1.0).to(actions.device, actions.dtype)[:, None]
    out = actions.clone()
    cols = list(range(actions.shape[1])) if columns is None else columns
    out[:, cols] = (1.0 - w) * actions[:, cols] + w * target.to(actions.device, actions.dtype)
    return out


def roll_pitch(gravity: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The trunk's roll ψ = atan2(g_y, −g_z) and pitch δ = −atan2(g_x, −g_z) (rad, each (k,))
    from the IMU's projected gravity ``gravity`` (k, 3): ψ > 0 with the left side down, δ > 0
    nose up."""
    g = gravity.to(torch.float32)
    return torch.atan2(g[:, 1], -g[:, 2]), -torch.atan2(g[:, 0], -g[:, 2])


def gravity_lean(gravity: torch.Tensor, gains: torch.Tensor) -> torch.Tensor:
    """(k, C) offsets to a pose's actions that lean its legs towards gravity: ``gravity`` (k, 3)
    is the IMU's projected gravity (down = (0, 0, −1) when upright), ``gains`` (2, C) multiply
    the trunk's roll ψ = atan2(g_y, −g_z) (row 0) and pitch δ = −atan2(g_x, −g_z) (row 1), in
    rad. On the A1 a hip column with gain 1/scale turns the leg about the trunk's x axis by ψ
    and a thigh column with gain 1/scale turns it about the y axis by δ: the feet move under
    the hips in the world, downhill of where a pose square to the slope puts them."""
    roll, pitch = roll_pitch(gravity)
    return roll[:, None] * gains[0].to(roll) + pitch[:, None] * gains[1].to(roll)


class LeanedPose:
    """A fixed pose's actions ``target`` (C,) plus ``gravity_lean`` with ``gains`` (2, C): called
    with the projected gravity (k, 3), the (k, C) target actions of a stance that leans."""

    def __init__(self, target, gains):
        self.target = torch.as_tensor(target, dtype=torch.float32)
        self.gains = torch.as_tensor(gains, dtype=torch.float32)
        if self.gains.shape != (2, len(self.target)):
            raise ValueError(f"lean gains are (2, columns) = (2, {len(self.target)}), got {tuple(self.gains.shape)}")

    def __call__(self, gravity: torch.Tensor) -> torch.Tensor:
        g = gravity.detach().cpu()
        return (self.target + gravity_lean(g, self.gains)).to(gravity.device)


StanceTarget = torch.Tensor | Callable[[torch.Tensor], torch.Tensor]
"""A stance's actions: fixed (C,), or a law of the trunk's projected gravity (k, 3) → (k, C)
(``LeanedPose``)."""


def target_for(target: StanceTarget, gravity: torch.Tensor) -> torch.Tensor:
    """``target`` itself when fixed, else ``target(gravity)``."""
    return target(gravity) if callable(target) else target


def lean_gains(robot, lean: tuple[float, float], columns: list[int] | None = None, scale_rad: float = 1.0
               ) -> np.ndarray | None:
    """(2, C) gains of ``gravity_lean`` for ``columns`` (all joints when None) of ``robot``:
    ``lean[0]`` times the roll on the hips, ``lean[1]`` times the pitch on the thighs, in rad
    per rad, or in action units with the action mapping's ``scale_rad``; None when both are 0
    (a fixed pose)."""
    if not any(lean):
        return None
    cols = list(range(len(robot.joint_names))) if columns is None else columns
    parts = [robot.joint_names[c].split("_")[1] for c in cols]
    return np.array([[lean[0] if p == "hip" else 0.0 for p in parts],
                     [lean[1] if p == "thigh" else 0.0 for p in parts]]) / scale_rad


def stance_action(robot, action: ActionConfig, leg: tuple[float, float, float]) -> np.ndarray:
    """(J,) the action, under the action mapping ``action``, whose targets are the hip, thigh and
    knee angles ``leg`` (rad) on every leg of ``robot``. Needs a fixed action reference."""
    return pose_action(robot, action, np.tile(np.asarray(leg, dtype=np.float64), len(robot.joint_names) // 3))


def pose_action(robot, action: ActionConfig, q: np.ndarray) -> np.ndarray:
    """(J,) the action, under the action mapping ``action``, whose joint targets are ``q`` (J,)
    rad. Needs a fixed action reference."""
    ref = robot.reference_pose(action.reference)
    if ref is None:
        raise ValueError("a fixed pose needs a fixed action reference (stand / tall), not 'current'")
    return (q - ref) / action.scale_rad
