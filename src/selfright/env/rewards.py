"""The seed's reward (Table I) as pure, unweighted terms.

Each term maps the robot state after a control step (and, where needed, the actions or the
episode's start point) to a tensor of shape (n,). Weights live only in
``selfright.train.config.RewardConfig``; ``weighted_rewards`` forms w_i · r_i · dt per term
and their sum, r_total = Σ_i w_i · r_i · dt.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import torch

from selfright.env.robot_state import RobotState
from selfright.config import RewardConfig


# ----------------------------------------------------------------------------- terms
def upright_cos(rs: RobotState) -> torch.Tensor:
    """(n,) cos θ_z: cosine of the angle between the trunk's up axis and world +z, in [−1, 1]."""
    return rs.up_z.float()


def vertical_velocity_kernel(rs: RobotState, sigma_sq: float) -> torch.Tensor:
    """(n,) φ(v_z) = exp(−v_z² / sigma_sq), v_z the trunk's world vertical velocity (m/s); in (0, 1]."""
    vz = rs.lin_vel[:, 2].float()
    return torch.exp(-vz.square() / sigma_sq)


def torque_l2(rs: RobotState) -> torch.Tensor:
    """(n,) −‖τ‖², τ (n, J) the motor torques (N²·m²)."""
    return -rs.torque.float().square().sum(dim=-1)


def base_height_l2(rs: RobotState, target_m: float | torch.Tensor) -> torch.Tensor:
    """(n,) −(z* − z)², z the trunk height above the ground beneath it and z* a scalar or
    (n,) target (m²)."""
    return -(torch.as_tensor(target_m, dtype=torch.float32) - rs.height.float()).square()


def body_collisions(rs: RobotState) -> torch.Tensor:
    """(n,) −n_c, n_c the number of non-foot bodies touching the ground."""
    return -rs.body_contacts.float()


def action_rate_l2(action: torch.Tensor, prev_action: torch.Tensor) -> torch.Tensor:
    """(n,) −‖a_t − a_{t−1}‖² over the (n, J) actions of this and the previous control step."""
    return -(action.float() - prev_action.float()).square().sum(dim=-1)


def horizontal_drift_l2(rs: RobotState, start_xy: torch.Tensor) -> torch.Tensor:
    """(n,) −‖xy_start − xy‖², trunk x-y (m) now against the (n, 2) start of the episode (m²)."""
    d = start_xy.to(torch.float64) - rs.pos[:, :2].to(torch.float64)
    return -d.square().sum(dim=-1).float()


def joint_limit_violation(rs: RobotState, low: torch.Tensor, high: torch.Tensor) -> torch.Tensor:
    """(n,) −Σ_j (max(0, q_j − high_j) + max(0, low_j − q_j)), joint angles (n, J) against
    their (J,) limits (rad).

    The seed's Table I prints this term without the leading minus (a sign slip: with a
    positive weight it would pay the policy for leaving the joint range); we implement the
    penalty, so the term is ≤ 0.
    """
    q = rs.q.float()
    over = (q - high.float()).clamp_min(0.0) + (low.float() - q).clamp_min(0.0)
    return -over.sum(dim=-1)


def all_feet_contact(rs: RobotState) -> torch.Tensor:
    """(n,) 1 where all four feet touch the ground, else 0."""
    return rs.feet_contact.all(dim=-1).float()


def goal_set_indicator(in_goal: torch.Tensor) -> torch.Tensor:
    """(n,) 1 while in the goal set, else 0. Not a Table I term: used only with a nonzero
    ``RewardConfig.goal_set`` weight (ablations)."""
    return in_goal.float()


def stance_kernel(rs: RobotState, leg_pose: tuple[float, float, float], sigma_sq: float,
                  max_tilt_deg: float = 30.0) -> torch.Tensor:
    """(n,) exp(−‖q − q*‖² / sigma_sq), q* ``leg_pose`` (hip, thigh, knee; rad) on every leg,
    where roll and pitch are each within ``max_tilt_deg`` (the goal set's tilt rule, as
    ``selfright.env.goal.upright``) with all feet down; 0 elsewhere. Not a Table I term: used
    only with a nonzero ``RewardConfig.stance`` weight (ablations)."""
    q = rs.q.float()
    target = torch.as_tensor(leg_pose, dtype=q.dtype, device=q.device).repeat(q.shape[-1] // 3)
    kernel = torch.exp(-(q - target).square().sum(dim=-1) / sigma_sq)
    tilt = math.radians(max_tilt_deg)
    gate = rs.feet_contact.all(dim=-1) & (rs.roll.abs() <= tilt) & (rs.pitch.abs() <= tilt)
    return kernel * gate.to(kernel.dtype)


def _upright_only(value: torch.Tensor, rs: RobotState, max_tilt_deg: float) -> torch.Tensor:
    """``value`` (n,) where the trunk's up axis is within ``max_tilt_deg`` of world z, else 0."""
    return value * (rs.up_z >= math.cos(math.radians(max_tilt_deg))).to(value.dtype)


def upright_spin_l2(rs: RobotState, max_tilt_deg: float = 45.0) -> torch.Tensor:
    """(n,) −‖ω‖² (trunk angular velocity, rad²/s²) where the up axis is within ``max_tilt_deg``
    of world z; 0 elsewhere. Not a Table I term: used only with a nonzero
    ``RewardConfig.upright_spin`` weight (ablations)."""
    return _upright_only(-rs.ang_vel.float().square().sum(dim=-1), rs, max_tilt_deg)


def upright_speed_l2(rs: RobotState, max_tilt_deg: float = 45.0) -> torch.Tensor:
    """(n,) −‖v_xy‖² (the trunk's horizontal velocity, m²/s²) where the up axis is within
    ``max_tilt_deg`` of world z; 0 elsewhere. Not a Table I term: used only with a nonzero
    ``RewardConfig.upright_speed`` weight (ablations)."""
    return _upright_only(-rs.lin_vel[:, :2].float().square().sum(dim=-1), rs, max_tilt_deg)


def refall_event(refell: torch.Tensor) -> torch.Tensor:
    """(n,) −1 where the robot has just fallen again after having been upright (``refell``,
    (n,) bool, detected by the training env, which keeps the memory of having been upright),
    else 0. Not a Table I term: an event term, paid once per re-fall with a nonzero
    ``RewardConfig.refall`` weight (ablations)."""
    return -refell.float()


def off_tile_event(left_tile: torch.Tensor) -> torch.Tensor:
    """(n,) −1 where the robot has just left its tile (``left_tile``, (n,) bool, which ends the
    episode), else 0. Not a Table I term: an event term, paid once, with a nonzero
    ``RewardConfig.off_tile`` weight (ablations)."""
    return -left_tile.float()


def standing_height(stand_height_m: float, slope_pct: torch.Tensor) -> torch.Tensor:
    """(n,) z* on tiles of grade ``slope_pct`` (n,) (%): the trunk height, measured vertically
    above the ground beneath as z is, of a robot standing square to the slope with its trunk
    ``stand_height_m`` from the ground: stand_height / cos(slope angle). 0.35 m on the
    plane, 0.372 m on the 20° incline."""
    return stand_height_m / torch.cos(torch.atan(slope_pct.float() / 100.0))


# ----------------------------------------------------------------------------- sum
@dataclass(frozen=True)
class RewardContext:
    """Per-step inputs of the reward beyond the robot state."""

    action: torch.Tensor
    """(n, J) clipped action of this control step."""
    prev_action: torch.Tensor
    """(n, J) clipped action of the previous control step (zeros at an episode's start)."""
    start_xy: torch.Tensor
    """(n, 2) trunk x-y when the policy took over (m)."""
    joint_low: torch.Tensor
    """(J,) lower joint limits (rad)."""
    joint_high: torch.Tensor
    """(J,) upper joint limits (rad)."""
    target_height_m: float | torch.Tensor
    """Standing height z* (m), a scalar or (n,) per env (see ``standing_height``)."""
    in_goal: torch.Tensor | None = None
    """(n,) bool, in the goal set after this step (needed only by the ``goal_set`` term)."""
    refell: torch.Tensor | None = None
    """(n,) bool, fell again this step after having been upright (needed only by ``refall``)."""
    left_tile: torch.Tensor | None = None
    """(n,) bool, left the tile this step (needed only by ``off_tile``)."""


def _needs(value: torch.Tensor | None, term: str, field: str) -> torch.Tensor:
    if value is None:
        raise ValueError(f"the {term} reward term needs RewardContext.{field}")
    return value


OptionalTerm = Callable[[RobotState, RewardContext, RewardConfig], torch.Tensor]
OPTIONAL_TERMS: dict[str, OptionalTerm] = {
    "goal_set": lambda rs, ctx, cfg: goal_set_indicator(_needs(ctx.in_goal, "goal_set", "in_goal")),
    "stance": lambda rs, ctx, cfg: stance_kernel(rs, cfg.stance_pose, cfg.stance_sigma_sq),
    "upright_spin": lambda rs, ctx, cfg: upright_spin_l2(rs, cfg.upright_spin_tilt_deg),
    "upright_speed": lambda rs, ctx, cfg: upright_speed_l2(rs, cfg.upright_spin_tilt_deg),
    "refall": lambda rs, ctx, cfg: refall_event(_needs(ctx.refell, "refall", "refell")),
    "off_tile": lambda rs, ctx, cfg: off_tile_event(_needs(ctx.left_tile, "off_tile", "left_tile")),
}
"""Terms outside Table I, each computed only where its ``RewardConfig`` weight (the field of
the same name) is nonzero; the default config trains on Table I exactly."""
EVENT_TERMS = frozenset({"refall", "off_tile"})
"""Terms paid once per event: weighted w · r, not w · r · dt."""


def reward_terms(rs: RobotState, ctx: RewardContext, cfg: RewardConfig) -> dict[str, torch.Tensor]:
    """Unweighted Table I terms by name, each (n,), plus those of ``OPTIONAL_TERMS`` whose
    weights are nonzero."""
    terms = {
        "orientation": upright_cos(rs),
        "vertical_velocity": vertical_velocity_kernel(rs, cfg.vz_sigma_sq),
        "torques": torque_l2(rs),
        "base_height": base_height_l2(rs, ctx.target_height_m),
        "collisions": body_collisions(rs),
        "action_rate": action_rate_l2(ctx.action, ctx.prev_action),
        "horizontal_drift": horizontal_drift_l2(rs, ctx.start_xy),
        "joint_limits": joint_limit_violation(rs, ctx.joint_low, ctx.joint_high),
        "feet_contact": all_feet_contact(rs),
    }
    for name, term in OPTIONAL_TERMS.items():
        if getattr(cfg, name) != 0.0:
            terms[name] = term(rs, ctx, cfg)
    return terms


def reward_weights(cfg: RewardConfig) -> dict[str, float]:
    """Weight of every term, keyed like ``reward_terms``."""
    weights = {
        "orientation": cfg.orientation,
        "vertical_velocity": cfg.vertical_velocity,
        "torques": cfg.torques,
        "base_height": cfg.base_height,
        "collisions": cfg.collisions,
        "action_rate": cfg.action_rate,
        "horizontal_drift": cfg.horizontal_drift,
        "joint_limits": cfg.joint_limits,
        "feet_contact": cfg.feet_contact,
    }
    weights.update({name: getattr(cfg, name) for name in OPTIONAL_TERMS if getattr(cfg, name) != 0.0})
    return weights


def weighted_rewards(
    rs: RobotState, ctx: RewardContext, cfg: RewardConfig, dt: float
) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """r_total (n,) = Σ_i w_i · r_i · dt, and every weighted term w_i · r_i · dt (n,) by name
    (``EVENT_TERMS``: w_i · r_i, paid once per event)."""
    terms = reward_terms(rs, ctx, cfg)
    weights = reward_weights(cfg)
    weighted = {name: weights[name] * value * (1.0 if name in EVENT_TERMS else dt) for name, value in terms.items()}
    total = torch.stack(list(weighted.values())).sum(dim=0)
    return total, weighted
