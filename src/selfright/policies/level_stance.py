"""A stance that stands on a slope: leg lengths and lean set each step from the IMU's gravity.

Held PD targets of a fixed pose tip the A1 over on the 20° incline at every heading
(``scripts/slope_stance.py``; docs/training.md, *What standing can reach*): the trunk shifts
downhill onto the downhill legs, which give. This law sets each leg's hip-to-foot length and
fore-aft lean from the trunk's roll ψ and pitch δ, read from the projected gravity g:

* ψ = atan2(g_y, −g_z), δ = −atan2(g_x, −g_z) (ψ > 0: the left side is down; δ > 0: nose up);
* leg length L = ``leg_m`` + ``roll_level`` · s · w · tan ψ − ``pitch_level`` · f · l · tan δ,
  s = +1 on the left legs, f = +1 on the front legs, w and l the feet's half-width and
  half-length: the legs on the low side reach further, levelling the trunk (clamped to the
  leg's reach at the knee's limit);
* knee = −κ, thigh = κ / 2 + ``pitch_lean`` · δ with L = 2 · link · cos(κ / 2): the foot under
  the hip, leaned by the pitch so that (at gain 1) the leg points along gravity fore and aft;
  hips at 0.

The feedback is negative where the obvious alternative is not: turning the hips by the roll
(``gravity_lean``) with the feet planted rolls the trunk further and feeds itself. Held by the
PD servos alone (no policy), the default law stands on the 20° slope at every heading, 11–16°
from vertical and 0.34–0.37 m over the ground beneath the trunk (``python
scripts/slope_stance.py --level``). Not in the seed: a hand-set posture, used as a stance the
students are distilled towards (``--train.distillation.stance-level``) or blended to at
evaluation (``scripts/policy_variants.py --pose-upright-level``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from selfright.config import ActionConfig
from selfright.policies.pose_blend import roll_pitch

LINK_M = 0.2
"""The A1's thigh and calf lengths (m), hip axis to knee and knee to foot centre."""
HALF_LENGTH_M = 0.183
"""Fore-aft distance of the A1's hips from the trunk's centre (m)."""
HALF_WIDTH_M = 0.132
"""Sideways distance of the A1's feet from the trunk's centre with the hips at 0 (m)."""


@dataclass(frozen=True)
class LevelStance:
    leg_m: float = 0.34
    """Hip-to-foot-centre length of every leg on level ground (m); the A1 reaches 0.359 m with
    its knee at the limit."""
    roll_level: float = 1.0
    """Share of the trunk's roll the leg lengths take out (1 = level across, if reachable)."""
    pitch_lean: float = 1.0
    """Gain of the thighs' turn by the trunk's pitch (1 = the legs along gravity fore and aft)."""
    pitch_level: float = 0.25
    """Share of the trunk's pitch the leg lengths take out. Levelling fully facing up or down a
    20° slope would leave the trunk under the goal bar (docs/training.md); a quarter keeps it over."""

    def __post_init__(self) -> None:
        if not 0.1 < self.leg_m <= 2 * LINK_M:
            raise ValueError(f"leg_m is a hip-to-foot length in (0.1, {2 * LINK_M}] m, got {self.leg_m}")

    def joints(self, gravity: torch.Tensor, knee_high: float) -> torch.Tensor:
        """(k, 12) joint targets (rad; legs FR, FL, RR, RL, each hip, thigh, knee) for the
        projected gravity ``gravity`` (k, 3); ``knee_high`` the knee's upper limit (rad, < 0)."""
        roll, pitch = roll_pitch(gravity)
        side = torch.tensor([-1.0, 1.0, -1.0, 1.0])  # FR, FL, RR, RL: +1 on the left
        front = torch.tensor([1.0, 1.0, -1.0, -1.0])
        length = (self.leg_m + self.roll_level * side * HALF_WIDTH_M * torch.tan(roll)[:, None]
                  - self.pitch_level * front * HALF_LENGTH_M * torch.tan(pitch)[:, None])
        reach = 2 * LINK_M * math.cos(abs(knee_high) / 2)
        kappa = 2 * torch.arccos(length.clamp(0.1, reach) / (2 * LINK_M))
        thigh = kappa / 2 + self.pitch_lean * pitch[:, None]
        return torch.stack([torch.zeros_like(kappa), thigh, -kappa], dim=2).reshape(len(gravity), 12)


class LevelStanceTarget:
    """``LevelStance`` as actions of ``robot`` under the action mapping ``action`` (a fixed
    reference): called with the projected gravity (k, 3), it gives (k, J) actions, or (k, C)
    for ``columns``."""

    def __init__(self, law: LevelStance, robot, action: ActionConfig, columns: list[int] | None = None):
        if len(robot.joint_names) != 12:
            raise ValueError(f"the level stance is the A1's (12 joints), got {len(robot.joint_names)}")
        ref = robot.reference_pose(action.reference)
        if ref is None:
            raise ValueError("a stance needs a fixed action reference (stand / tall), not 'current'")
        self.law, self.cols = law, list(range(12)) if columns is None else list(columns)
        self.ref = torch.as_tensor(np.asarray(ref), dtype=torch.float32)
        self.scale = float(action.scale_rad)
        self.low = torch.as_tensor(np.asarray(robot.joint_low), dtype=torch.float32)
        self.high = torch.as_tensor(np.asarray(robot.joint_high), dtype=torch.float32)
        self.knee_high = float(robot.joint_high[2])

    def __call__(self, gravity: torch.Tensor) -> torch.Tensor:
        q = torch.maximum(torch.minimum(self.law.joints(gravity.detach().cpu(), self.knee_high), self.high), self.low)
        return ((q - self.ref) / self.scale)[:, self.cols].to(gravity.device)
