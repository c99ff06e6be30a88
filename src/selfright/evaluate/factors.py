"""The seed's further factors as command-line flags, shared by ``selfright evaluate`` and ``replay``.

Torch-free on purpose: ``selfright.cli`` imports it at start-up. Defaults are ``EvalConfig``'s,
so the benchmark's conditions are stated once.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from selfright.config import EvalConfig


@dataclass(frozen=True)
class FurtherFactors:
    """Friction, side walls, ground compliance and sensor noise of every evaluated cell."""

    friction: float = EvalConfig.friction
    """Ground friction of every cell."""
    wall_gap_ratio: float | None = EvalConfig.wall_gap_ratio
    """Confined space: side walls this many body lengths apart (default: none)."""
    ground_timeconst: float = EvalConfig.ground_timeconst_s
    """Ground compliance: contact time constant (s); larger = softer."""
    sensor_noise: float = EvalConfig.sensor_noise
    """Sensor noise: Gaussian noise on what the policy senses, in multiples of IMU gravity 0.05, gyro 0.2 rad/s, joint angles 0.01 rad, joint speeds 1.5 rad/s (default 0: exact sensors)."""

    def factor_kwargs(self) -> dict[str, float | None]:
        """The factors as ``EvalConfig`` keyword arguments."""
        return {"friction": self.friction, "wall_gap_ratio": self.wall_gap_ratio,
                "ground_timeconst_s": self.ground_timeconst, "sensor_noise": self.sensor_noise}

    def apply(self, eval_cfg: EvalConfig) -> EvalConfig:
        """``eval_cfg`` under these factors."""
        return dataclasses.replace(eval_cfg, **self.factor_kwargs())
