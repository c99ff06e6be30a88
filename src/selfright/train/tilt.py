"""The tilt rule of the distillation teachers: per env, is the trunk tilted more than
``tilt_deg`` from upright, read from the IMU's projected gravity (columns 0:3 of the student
and teacher observations, (0, 0, −1) when upright). A function of the current observation
alone, so a one-frame student can learn the labels a rule of it makes."""

from __future__ import annotations

import math

import torch


class TiltSwitch:
    """``step(x)``: (k,) bool, the trunk's up axis more than ``tilt_deg`` from world z, for
    observations ``x`` (k, D) whose first three columns are the projected gravity."""

    def __init__(self, tilt_deg: float):
        if not 0.0 < tilt_deg < 180.0:
            raise ValueError(f"tilt_deg must lie in (0, 180), got {tilt_deg}")
        self.tilt_deg = tilt_deg
        self._cos = math.cos(math.radians(tilt_deg))

    def step(self, x: torch.Tensor) -> torch.Tensor:
        """(k,) bool on the CPU: tilted over."""
        return -x[:, 2].detach().cpu() < self._cos
