"""The torque-speed envelope of a DC motor whose drive voltage saturates, as a limit on PD
joint targets.

A DC motor with stall torque τ_s and no-load speed ω₀ gives at joint speed ω a torque within
[max(−τ_s, −τ_s (1 + ω/ω₀)), min(τ_s, τ_s (1 − ω/ω₀))]. An ideal PD servo asks
τ = Kp (q* − q) − Kd q̇. Moving the target to q*' = q + (clip(τ) + Kd q̇) / Kp makes the servo
ask exactly the clipped torque at (q, q̇). Two users: ``selfright.policies.torque_envelope``
(a DC-trained policy run on the ideal servos) and ``RobotConfig.motor = "envelope"`` (the env
applies the same limit to every policy, so a policy can be trained with it in the loop).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:
    import numpy as np
    import torch

Array = TypeVar("Array", "np.ndarray", "torch.Tensor")
"""The functions below work on numpy arrays and torch tensors alike (``selfright.deploy`` runs
them without torch), with the same arithmetic either way."""

__all__ = ["envelope_speed", "envelope_limits", "enveloped_targets", "envelope_held_targets"]


def envelope_speed(motor_speed: float | None, rated_speed: float | None, robot_name: str) -> float:
    """The no-load speed (rad/s) of the envelope: ``motor_speed`` if given
    (``RobotConfig.motor_speed_rad_s``), else the robot's rated joint speed."""
    speed = motor_speed or rated_speed
    if not speed or speed <= 0:
        raise ValueError(f"robot {robot_name!r} has no rated joint speed; give RobotConfig.motor_speed_rad_s")
    return float(speed)


def envelope_limits(qd: Array, stall_torque: float, speed: float) -> tuple[Array, Array]:
    """(low, high) torque bounds (N·m) of a voltage-saturated DC motor at joint speeds ``qd``
    (rad/s), stall torque ``stall_torque``, no-load speed ``speed`` (rad/s)."""
    high = (stall_torque * (1.0 - qd / speed)).clip(max=stall_torque)
    low = (-stall_torque * (1.0 + qd / speed)).clip(min=-stall_torque)
    return low, high


def enveloped_targets(target: Array, q: Array, qd: Array, kp: float, kd: float,
                      stall_torque: float, speed: float) -> Array:
    """Joint targets whose PD torque at (``q``, ``qd``) is that of ``target`` clipped to the DC
    envelope (``envelope_limits``)."""
    tau = kp * (target - q) - kd * qd
    low, high = envelope_limits(qd, stall_torque, speed)
    return q + (tau.clip(low, high) + kd * qd) / kp


def envelope_held_targets(target: Array, ref: Array, q: Array, qd: Array, scale: float, clip: float,
                          low: Array, high: Array, kp: float, kd: float, stall_torque: float, speed: float) -> Array:
    """What the ``envelope`` env commands: ``target`` moved into the DC envelope
    (``enveloped_targets``), then back through the action clip (±``clip`` actions of ``scale`` rad
    around the reference pose ``ref``) and the joint range ``low``–``high``."""
    moved = enveloped_targets(target, q, qd, kp, kd, stall_torque, speed)
    return (ref + scale * ((moved - ref) / scale).clip(-clip, clip)).clip(low, high)
