"""Running a policy trained on DC motors (``RobotConfig.motor = "dcmotor"``) on the ideal
servos, by limiting its own commands to the DC motors' torque-speed envelope.

A DC motor whose drive voltage saturates gives at joint speed ω a torque within
[max(−τ_s, −τ_s (1 + ω/ω₀)), min(τ_s, τ_s (1 − ω/ω₀))] (stall torque τ_s, no-load speed ω₀):
full torque at rest, none forward at ω₀, more than τ_s braking is clipped to τ_s. The ideal
servo gives τ = clip(Kp (q* − q) − Kd q̇, ±τ_s) at any speed. ``TorqueEnvelope`` reads the
sensed joint angles and speeds, works out the torque the policy's target would ask for,
clips it to the envelope, and moves the target so that the servo asks exactly that torque
at the start of the control step: q*' = q + (τ_clipped + Kd q̇) / Kp. Within the step the
servo's torque then follows its PD law from there, so the envelope holds at 50 Hz, not at
every physics step: an approximation of the DC motor that needs nothing a real robot lacks.
The inner policy sees its own previous action, as it did in training (the motor never
changed its targets).
"""

from __future__ import annotations

import hashlib

import numpy as np
import torch

from selfright.config import ActionConfig, RobotConfig
from selfright.env.observations import JOINT_VEL_SCALE, joint_vel_columns, prev_action_columns
from selfright.policies.base import Policy
from selfright.policies.baselines import TargetPolicy, joint_angles
from selfright.policies.slots import LastActions
from selfright.robots import RobotSpec
from selfright.sim.dc_envelope import envelope_limits, envelope_speed, enveloped_targets

__all__ = ["TorqueEnvelope", "envelope_limits", "enveloped_targets"]


class TorqueEnvelope(TargetPolicy):
    """``inner`` (actions in the env's units) with each joint's commanded torque held to the
    DC motors' torque-speed envelope (module docstring).

    Args:
        inner: the policy, already converted to the env's action mapping.
        robot: the robot spec (nominal pose, joint range, stall torque, rated speed).
        action: the env's action mapping (a fixed reference pose; ``current`` works too).
        motor: the env's PD gains (``kp``, ``kd``) and, if set, the no-load speed
            ``motor_speed_rad_s`` (default: the robot's rated speed).
    """

    def __init__(self, inner: Policy, robot: RobotSpec, action: ActionConfig, motor: RobotConfig):
        speed = envelope_speed(motor.motor_speed_rad_s, robot.rated_joint_speed, robot.name)
        super().__init__(robot, action)
        self.inner = inner
        self.kp, self.kd, self.speed, self.stall = motor.kp, motor.kd, speed, float(robot.torque_limit)
        self.groups = tuple(sorted(set(inner.groups) | {"student"}))
        self.group = getattr(inner, "group", None)
        """The observation group the network reads (a file policy's), as the inner policy's."""
        self.action_mapping, self.trained_motor = inner.action_mapping, inner.trained_motor
        self.digest = None if inner.digest is None else (
            hashlib.sha256(f"{inner.digest}/dc-envelope/{self.speed:g}".encode()).hexdigest()[:16])
        self.name = f"{inner.name} in a DC torque envelope ({self.speed:g} rad/s)"
        J = len(robot.joint_names)
        self.cols = joint_vel_columns(J), prev_action_columns(J)
        self._memory = LastActions(J)
        """The inner policy's own last action per slot (what it observes as its previous one)."""

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.inner.reset(ids, seeds)
        self._memory.reset(ids)

    @torch.no_grad()
    def act(self, obs, ids, cells):
        m = self._memory
        t = m.slots(ids)
        vel, prev = self.cols
        took = ~m.fresh[t]
        own = {}
        for g, x in obs.items():  # the inner policy's own previous action, in every group that holds it
            x = x.clone()
            x[took, prev] = m.last[t][took].to(x.dtype)
            own[g] = x
        a = self.inner.act(own, ids, cells)
        mine = a.detach().float().cpu()
        m.last[t], m.fresh[t] = mine, False
        s = obs["student"].float().cpu()
        q, qd = joint_angles(s, self.robot), s[:, vel] / JOINT_VEL_SCALE
        new = enveloped_targets(self.to_target(mine, q), q, qd, self.kp, self.kd, self.stall, self.speed)
        return self.to_action(new, q).to(a.device, a.dtype)
