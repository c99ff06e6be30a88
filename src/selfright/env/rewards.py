"""The seed's reward (Table I) as pure, unweighted terms.

Each term maps the robot state after a control step (and, where needed, the joint targets or
the episode's start point) to a tensor of shape (n,). Weights live only in
``RewardConfig``; ``weighted_rewards`` forms w_i · r_i · dt per term
and their sum, r_total = Σ_i w_i · r_i · dt.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from selfright.env.robot_state import RobotState


@dataclass(frozen=True, kw_only=True)
class RewardConfig:
    """Weights of the seed's reward terms (Table I). r_total = Σ w_i · r_i · dt."""

    orientation: float = 2.5
    """Weight of cos θ_z, the trunk up axis against world z (per s)."""
    vertical_velocity: float = 0.1
    """Weight of exp(−v_z² / vz_sigma_sq), v_z the trunk's vertical speed (per s)."""
    torques: float = 0.001
    """Weight of −‖τ‖², τ the motor torques (per N²·m²·s)."""
    base_height: float = 40.0
    """Weight of −(z* − z)², z the body height over the feet (``RobotState.height_over_feet``) (per m²·s)."""
    collisions: float = 1.0
    """Weight of −n_c, the number of non-foot bodies touching the ground (per s)."""
    action_rate: float = 0.01
    """Weight of −‖q*_t − q*_{t−1}‖², q* the PD joint targets (rad) (per rad²·s)."""
    horizontal_drift: float = 0.01
    """Weight of −‖xy_start − xy‖², trunk x-y displacement since the policy started (per m²·s)."""
    joint_limits: float = 10.0
    """Weight of −Σ_j (excess of q_j beyond its limits), rad (per rad·s)."""
    feet_contact: float = 8.0
    """Weight of 1 when all four feet touch the ground, else 0 (per s)."""
    goal_set: float = 0.0
    """**Not in Table I.** Weight of 1 while the robot is in the benchmark's goal set (upright,
    four feet down, trunk over the bar), else 0 (per s). 0 = Table I exactly. Table I alone
    separates a crouch at 0.30 m from a stance at 0.35 m by 0.1/s (the base-height term) against
    8/s for four feet down, so on slopes its optimum can sit under the goal bar; this term pays for
    being over it. A model card names it when its policy used it."""
    bar_ramp: float = 0.0
    """**Not in Table I.** Weight of the bar ramp: while the robot stands upright on four feet
    (the goal set's tilt and contact conditions), clamp((z − (top − w)) / w, 0, 1) with z the
    body height over the feet, top = the goal set's height bar + ``bar_ramp_over_m`` and w
    ``bar_ramp_width_m``; else 0 (per s). 0 = off. Table I's base-height term changes by 0.1/s
    between 0.30 and 0.35 m; this term pays each centimetre of a stance up to just over the bar,
    a gradient toward it. A model card names it when its policy used it."""
    bar_ramp_width_m: float = 0.1
    """Width w of the bar ramp (m): a stance w under its top earns 0, one at its top the full weight."""
    bar_ramp_over_m: float = 0.02
    """How far over the goal bar the bar ramp tops out (m): a margin against standing on the bar."""
    feet_under_hips: float = 0.0
    """**Not in Table I.** Weight of −Σ_legs ‖h_leg‖² while the robot stands upright on four feet
    (the goal set's tilt and contact conditions), else 0 (per m²·s), h_leg the horizontal (world
    x-y) offset of a foot's centre from its leg root (``RobotSpec.leg_roots_m``, the thigh joint
    at zero abduction). 0 = off. Legs under their hips are as tall as their knees let them be; a
    stance with splayed or slanted legs stands lower for the same knee angle. A model card names
    it when its policy used it."""
    vz_sigma_sq: float = 0.25
    """Width of the vertical-velocity kernel φ(v_z) = exp(−v_z² / vz_sigma_sq) (m²/s²)."""
    target_height_m: float | None = None
    """Standing height z* of the base-height term, a height over the feet (m), the same on every
    terrain; ``None`` = the robot's standing height (``RobotSpec.stand_height_m``, 0.35 m on the
    A1). The feet follow the slope, so z* needs no slope correction: a robot square to a 20°
    slope stands 0.35 m × cos 20° = 0.33 m over its feet, and z* asks it to bring its legs
    toward the vertical, away from the goal set's bar. The seed leaves z* unspecified; the default
    targets the height the robot has when standing in the goal set, not the goal's lower bar
    (0.8 × leg length = 0.32 m): with z* on the bar, nothing in Table I rewards standing above
    it, and policies trained that way stood at 0.30–0.32 m, half outside the goal set."""


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
    """(n,) −(z* − z)², z the body height over the feet (``RobotState.height_over_feet``) and
    z* a scalar or (n,) target (m²)."""
    return -(torch.as_tensor(target_m, dtype=torch.float32) - rs.height_over_feet.float()).square()


def body_collisions(rs: RobotState) -> torch.Tensor:
    """(n,) −n_c, n_c the number of non-foot bodies touching the ground."""
    return -rs.body_contacts.float()


def action_rate_l2(joint_target: torch.Tensor, prev_joint_target: torch.Tensor) -> torch.Tensor:
    """(n,) −‖q*_t − q*_{t−1}‖² (rad²) over the (n, J) PD joint targets of this and the previous
    control step (after the action mapping and the clip to the joint range), as Table I writes it."""
    return -(joint_target.float() - prev_joint_target.float()).square().sum(dim=-1)


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


def bar_ramp(rs: RobotState, stance: torch.Tensor, top_m: float, width_m: float) -> torch.Tensor:
    """(n,) clamp((z − (top_m − width_m)) / width_m, 0, 1) where ``stance`` ((n,) bool: upright on
    four feet), else 0; z the body height over the feet (m). Not a Table I term."""
    ramp = ((rs.height_over_feet.float() - (top_m - width_m)) / width_m).clamp(0.0, 1.0)
    return ramp * stance.float()


def feet_under_hips(rs: RobotState, stance: torch.Tensor, leg_roots_b: torch.Tensor) -> torch.Tensor:
    """(n,) −Σ_legs ‖h_leg‖² (m²) where ``stance`` ((n,) bool: upright on four feet), else 0;
    h_leg the world x-y offset of the foot centre (``RobotState.feet_pos``) from its leg root,
    ``leg_roots_b`` (F, 3) in the trunk frame placed by the trunk's pose. Not a Table I term."""
    roots = rs.pos.to(torch.float64)[:, None, :] + torch.einsum(
        "nij,fj->nfi", rs.rot.to(torch.float64), leg_roots_b.to(torch.float64))
    offset = (rs.feet_pos.to(torch.float64) - roots)[:, :, :2]
    return -offset.square().sum(dim=(1, 2)).float() * stance.float()


def goal_set_indicator(in_goal: torch.Tensor) -> torch.Tensor:
    """(n,) 1 while in the goal set (``in_goal``, (n,) bool), else 0. Not a Table I term."""
    return in_goal.float()


# ----------------------------------------------------------------------------- sum
@dataclass(frozen=True)
class RewardContext:
    """Per-step inputs of the reward beyond the robot state."""

    joint_target: torch.Tensor
    """(n, J) PD joint targets q* of this control step (rad, ``RecoveryEnv.joint_target``)."""
    prev_joint_target: torch.Tensor
    """(n, J) PD joint targets of the previous control step (rad; at an episode's start, its
    joint angles)."""
    start_xy: torch.Tensor
    """(n, 2) trunk x-y when the policy took over (m)."""
    joint_low: torch.Tensor
    """(J,) lower joint limits (rad)."""
    joint_high: torch.Tensor
    """(J,) upper joint limits (rad)."""
    target_height_m: float | torch.Tensor
    """Standing height z* over the feet (m), a scalar or (n,) per env."""
    in_goal: torch.Tensor | None = None
    """(n,) bool, in the goal set after this step; needed only by the ``goal_set`` term."""
    stance: torch.Tensor | None = None
    """(n,) bool, upright on four feet after this step; needed only by the ``bar_ramp`` term."""
    goal_bar_m: float | None = None
    """The goal set's height bar (m); needed only by the ``bar_ramp`` term."""
    leg_roots_m: torch.Tensor | None = None
    """(F, 3) leg roots in the trunk frame (m, ``RobotSpec.leg_roots_m``); needed only by the
    ``feet_under_hips`` term."""


def reward_terms(rs: RobotState, ctx: RewardContext, cfg: RewardConfig) -> dict[str, torch.Tensor]:
    """Unweighted Table I terms by name, each (n,), plus ``goal_set``, ``bar_ramp`` and
    ``feet_under_hips`` where their weights are nonzero."""
    terms = {
        "orientation": upright_cos(rs),
        "vertical_velocity": vertical_velocity_kernel(rs, cfg.vz_sigma_sq),
        "torques": torque_l2(rs),
        "base_height": base_height_l2(rs, ctx.target_height_m),
        "collisions": body_collisions(rs),
        "action_rate": action_rate_l2(ctx.joint_target, ctx.prev_joint_target),
        "horizontal_drift": horizontal_drift_l2(rs, ctx.start_xy),
        "joint_limits": joint_limit_violation(rs, ctx.joint_low, ctx.joint_high),
        "feet_contact": all_feet_contact(rs),
    }
    if cfg.goal_set != 0.0:
        if ctx.in_goal is None:
            raise ValueError("the goal_set reward term needs RewardContext.in_goal")
        terms["goal_set"] = goal_set_indicator(ctx.in_goal)
    if cfg.bar_ramp != 0.0:
        if ctx.stance is None or ctx.goal_bar_m is None:
            raise ValueError("the bar_ramp reward term needs RewardContext.stance and goal_bar_m")
        terms["bar_ramp"] = bar_ramp(rs, ctx.stance, ctx.goal_bar_m + cfg.bar_ramp_over_m, cfg.bar_ramp_width_m)
    if cfg.feet_under_hips != 0.0:
        if ctx.stance is None or ctx.leg_roots_m is None:
            raise ValueError("the feet_under_hips reward term needs RewardContext.stance and leg_roots_m")
        terms["feet_under_hips"] = feet_under_hips(rs, ctx.stance, ctx.leg_roots_m)
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
    if cfg.goal_set != 0.0:
        weights["goal_set"] = cfg.goal_set
    if cfg.bar_ramp != 0.0:
        weights["bar_ramp"] = cfg.bar_ramp
    if cfg.feet_under_hips != 0.0:
        weights["feet_under_hips"] = cfg.feet_under_hips
    return weights


def weighted_rewards(
    rs: RobotState, ctx: RewardContext, cfg: RewardConfig, dt: float
) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """r_total (n,) = Σ_i w_i · r_i · dt, and every weighted term w_i · r_i · dt (n,) by name."""
    terms = reward_terms(rs, ctx, cfg)
    weights = reward_weights(cfg)
    weighted = {name: weights[name] * value * dt for name, value in terms.items()}
    total = torch.stack(list(weighted.values())).sum(dim=0)
    return total, weighted
