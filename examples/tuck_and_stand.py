"""A minimal hand-written recovery policy, to show how to benchmark your own controller.

    selfright evaluate --policy examples/tuck_and_stand.py:TuckAndStand --grid flat --episodes 16

Upside down or on its side the robot folds its legs to the nominal (crouched) pose; once the
IMU says the trunk is within 45° of upright it extends them to the standing pose. No learning:
it gets up only from falls that come to rest nearly upright (1.6 % of 64 falls on `--grid flat`,
seed 0; the scripted `open-loop` baseline 25 %, the shipped `flat` 98.4 %).
"""

from __future__ import annotations

import math

import torch

from selfright.config import BenchmarkConfig
from selfright.env.observations import GRAVITY_COLUMNS
from selfright.policies.base import Policy
from selfright.robots import get_robot


class TuckAndStand(Policy):
    """Reads the ``student`` observation; actions follow the evaluation's action mapping
    (joint targets = reference pose + scale × action, the standing pose by default)."""

    groups = ("student",)

    def __init__(self, cfg: BenchmarkConfig):
        robot = get_robot(cfg.robot.name)
        reference = torch.as_tensor(robot.reference_pose(cfg.action.reference), dtype=torch.float32)
        self.tuck = (torch.as_tensor(robot.nominal_pose, dtype=torch.float32) - reference) / cfg.action.scale_rad
        self.stand = (torch.as_tensor(robot.stand_pose, dtype=torch.float32) - reference) / cfg.action.scale_rad
        self.cos_upright = math.cos(math.radians(45.0))

    def act(self, obs, ids, contexts):
        gravity = obs["student"][:, GRAVITY_COLUMNS]  # (k, 3), (0, 0, -1) when upright
        upright = (-gravity[:, 2] > self.cos_upright)[:, None]
        return torch.where(upright, self.stand, self.tuck)
