"""Per-episode domain randomisation: ground friction, PD gains and robot masses; per-step
sensor noise on the student's observation.

Factors are drawn uniformly from ``RandomizationConfig`` with an explicit generator and
written into a private copy of the episode's ``MjModel`` (``RecoveryEnv.reset`` accepts one
model per slot). The same factors go into ``RecoveryEnv.factors`` / ``RecoveryEnv.friction``,
which the teacher observes. The sensor noise (``RandomizationConfig.sensor_noise``) is added
by ``selfright.train.vecenv`` to the ``student`` observation group.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import mujoco
import numpy as np
import torch

from selfright.robots import RobotSpec
from selfright.sim.scene import TERRAIN_GEOM


@dataclass(frozen=True, kw_only=True)
class RandomizationConfig:
    """Per-episode uniform domain randomisation, written into per-slot MuJoCo models."""

    enabled: bool = True
    """Randomise at all; when off every episode runs on its world's nominal model."""
    friction: tuple[float, float] = (0.4, 1.2)
    """Ground sliding friction ~ U(low, high) (dimensionless)."""
    kp_scale: tuple[float, float] = (0.8, 1.2)
    """PD stiffness multiplier ~ U(low, high) (dimensionless)."""
    kd_scale: tuple[float, float] = (0.8, 1.2)
    """PD damping multiplier ~ U(low, high) (dimensionless)."""
    mass_scale: tuple[float, float] = (0.9, 1.1)
    """Multiplier of every robot body's mass and inertia ~ U(low, high) (dimensionless)."""
    sensor_noise: float = 0.0
    """Additive Gaussian noise on the ``student`` observation group each control step (and so on
    the student's history frames), as a multiple of ``selfright.env.observations.SENSOR_NOISE_STD``
    (at 1: IMU gravity 0.05, gyro 0.2 rad/s, joint angles 0.01 rad, joint speeds 1.5 rad/s; none
    on the previous action). The teacher group and distillation labels stay exact. Students only
    (a teacher run refuses it); they are validated under the same noise. 0 (or ``enabled``
    off) = exact sensors."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.sensor_noise) and self.sensor_noise >= 0.0):
            raise ValueError(f"--train.randomization.sensor-noise must be a finite number >= 0 "
                             f"(a multiple of the sensors' noise std; 0 = exact sensors), got {self.sensor_noise}")

    @property
    def active_sensor_noise(self) -> float:
        """``sensor_noise`` when randomisation is on, else 0 (``enabled`` off turns it off too)."""
        return self.sensor_noise if self.enabled else 0.0


@dataclass(frozen=True)
class EpisodeFactors:
    """Randomised physical factors of k episodes, each (k,)."""

    friction: np.ndarray
    """Ground sliding friction (dimensionless)."""
    mass_scale: np.ndarray
    """Multiplier of every robot body's mass and inertia."""
    kp_scale: np.ndarray
    """Multiplier of the PD stiffness."""
    kd_scale: np.ndarray
    """Multiplier of the PD damping."""

    def as_array(self) -> np.ndarray:
        """(k, 4) float64: friction, mass, Kp, Kd scales (``from_array`` inverts it exactly)."""
        return np.stack([self.friction, self.mass_scale, self.kp_scale, self.kd_scale], axis=1)

    @staticmethod
    def from_array(a: np.ndarray) -> EpisodeFactors:
        return EpisodeFactors(friction=a[:, 0], mass_scale=a[:, 1], kp_scale=a[:, 2], kd_scale=a[:, 3])

    def as_tensor(self) -> torch.Tensor:
        """(k, 3) mass, Kp, Kd scales, the column order of ``RecoveryEnv.factors``."""
        return torch.from_numpy(np.stack([self.mass_scale, self.kp_scale, self.kd_scale], axis=1)).float()


def sample_factors(k: int, cfg: RandomizationConfig, rng: np.random.Generator) -> EpisodeFactors:
    """Draw the factors of ``k`` episodes, each uniform on its configured range."""
    u = lambda bounds: rng.uniform(bounds[0], bounds[1], size=k)  # noqa: E731
    return EpisodeFactors(
        friction=u(cfg.friction), mass_scale=u(cfg.mass_scale), kp_scale=u(cfg.kp_scale), kd_scale=u(cfg.kd_scale)
    )


DCMOTOR_KP, DCMOTOR_KD = 4, 6
"""Where MuJoCo's ``dcmotor`` actuator keeps its controller's torque-space kp and kd in
``gainprm`` (after resistance and motor constant; ``tests/test_model.py`` checks it)."""


class ModelRandomizer:
    """Writes episode factors into copies of a world's model.

    MuJoCo ids are looked up by name once, here: the terrain geom, the robot's bodies (the
    trunk's subtree) and the PD actuators (position servos: force = kp·(target − q) − kd·q̇,
    i.e. ``gainprm[0] = kp``, ``biasprm[1] = −kp``, ``biasprm[2] = −kd``; or, with
    ``RobotConfig.motor = "dcmotor"``, the DC motors' controller gains ``gainprm[DCMOTOR_KP]``,
    ``gainprm[DCMOTOR_KD]``).
    """

    def __init__(self, template: mujoco.MjModel, robot: RobotSpec):
        self.terrain_geom = template.geom(TERRAIN_GEOM).id
        trunk = template.body(robot.trunk_body).id
        self.bodies = np.array([b for b in range(template.nbody) if _in_subtree(template, b, trunk)])
        self.actuators = np.array([template.actuator(j.removesuffix("_joint")).id for j in robot.joint_names])
        self.dcmotor = bool(np.all(template.actuator_gaintype[self.actuators] == mujoco.mjtGain.mjGAIN_DCMOTOR))

    def apply(self, base: mujoco.MjModel, friction: float, mass: float, kp: float, kd: float) -> mujoco.MjModel:
        """A copy of ``base`` with the ground friction set and masses, inertias, Kp, Kd scaled."""
        m = copy.copy(base)
        m.geom_friction[self.terrain_geom, 0] = friction
        m.body_mass[self.bodies] = base.body_mass[self.bodies] * mass
        m.body_inertia[self.bodies] = base.body_inertia[self.bodies] * mass
        a = self.actuators
        if self.dcmotor:  # the controller's torque-space gains
            m.actuator_gainprm[a, DCMOTOR_KP] = base.actuator_gainprm[a, DCMOTOR_KP] * kp
            m.actuator_gainprm[a, DCMOTOR_KD] = base.actuator_gainprm[a, DCMOTOR_KD] * kd
            return m
        m.actuator_gainprm[a, 0] = base.actuator_gainprm[a, 0] * kp
        m.actuator_biasprm[a, 1] = base.actuator_biasprm[a, 1] * kp
        m.actuator_biasprm[a, 2] = base.actuator_biasprm[a, 2] * kd
        return m

    def models(self, bases: list[mujoco.MjModel], f: EpisodeFactors) -> list[mujoco.MjModel]:
        """One randomised copy per episode, ``bases[i]`` with the i-th factors."""
        return [
            self.apply(b, f.friction[i], f.mass_scale[i], f.kp_scale[i], f.kd_scale[i]) for i, b in enumerate(bases)
        ]


def _in_subtree(model: mujoco.MjModel, body: int, root: int) -> bool:
    while body > 0:
        if body == root:
            return True
        body = int(model.body_parentid[body])
    return root == 0
