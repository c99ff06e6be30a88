"""Sensor noise at evaluation: a policy reading its sensors through additive Gaussian noise.

The benchmark's sensors are exact by default. A real A1's IMU and joint encoders are not, and a
policy trained on exact sensors can depend on them far more than its success suggests.
``selfright evaluate --sensor-noise S`` (``EvalConfig.sensor_noise``) wraps every policy in
``NoisySensors`` (docs/benchmark.md, *Further factors*).
"""

from __future__ import annotations

import numpy as np
import torch

from selfright.env.observations import sensor_noise_std
from selfright.policies.base import Policy
from selfright.policies.slots import SlotNoise


class NoisySensors(Policy):
    """``inner`` reading sensors with additive Gaussian noise: ``scale`` × ``SENSOR_NOISE_STD``
    on the ``student`` observation (IMU gravity and gyro, joint angles and speeds; not the previous
    action) and on the same columns of the ``teacher`` observation (its privileged part stays
    exact), one draw per step shared by both, seeded per episode (``stream`` picks one of
    independent sequences). A robustness test of a policy's sensing, not the benchmark's default."""

    def __init__(self, inner: Policy, scale: float, num_joints: int = 12, stream: int = 0):
        if scale <= 0:
            raise ValueError(f"sensor noise scale must be > 0, got {scale}")
        self.inner, self.stream = inner, int(stream)
        self.std = float(scale) * sensor_noise_std(num_joints)
        self.groups, self.action_mapping, self.digest = inner.groups, inner.action_mapping, inner.digest
        self.name = f"{inner.name} (sensor noise x{scale:g})"
        self._noise = SlotNoise(11, self.stream)

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self._noise.reset(ids, seeds, "NoisySensors")
        self.inner.reset(ids, seeds)

    def act(self, obs, ids, cells):
        d = len(self.std)
        noise = self.std * self._noise.draw(ids, d)
        noisy = dict(obs)
        if "student" in obs:
            noisy["student"] = obs["student"] + noise
        if "teacher" in obs:
            noisy["teacher"] = torch.cat([obs["teacher"][:, :d] + noise, obs["teacher"][:, d:]], dim=1)
        return self.inner.act(noisy, ids, cells)
