"""Reward terms (Table I) on hand-set robot states, against hand-computed values."""

from __future__ import annotations

import dataclasses
import math

import pytest
import torch

from selfright.env import rewards as R
from selfright.env.robot_state import RobotState
from selfright.env.rewards import RewardConfig

J = 12
LOW = torch.full((J,), -1.0)
HIGH = torch.full((J,), 1.0)


def rot_x(angle: float) -> torch.Tensor:
    c, s = math.cos(angle), math.sin(angle)
    return torch.tensor([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def make_ctx(**events: torch.Tensor) -> R.RewardContext:
    """The three envs' reward context: unchanged joint targets, started at the origin, z* 0.32 m;
    ``events`` the optional fields."""
    return R.RewardContext(
        joint_target=torch.zeros(3, J), prev_joint_target=torch.zeros(3, J), start_xy=torch.zeros(3, 2, dtype=torch.float64),
        joint_low=LOW, joint_high=HIGH, target_height_m=0.32, **events,
    )


def make_state() -> RobotState:
    """Three envs: upright and standing; on its side; upside down."""
    n = 3
    q = torch.zeros(n, J)
    q[1, 0] = 1.1  # 0.1 rad above the upper limit
    q[2, 1] = -1.2  # 0.2 below the lower limit
    q[2, 2] = 1.05  # 0.05 above the upper limit
    torque = torch.zeros(n, J)
    torque[1] = 1.0  # ‖τ‖² = 12
    torque[2, :2] = torch.tensor([3.0, 4.0])  # ‖τ‖² = 25
    feet = torch.tensor([[True] * 4, [True, True, True, False], [False] * 4])
    # foot centres: lowest points (centre − 0.02 m) average 0.0, 0.30 and 0.05 m
    feet_z = torch.tensor([[0.02] * 4, [0.32, 0.36, 0.30, 0.30], [0.07] * 4], dtype=torch.float64)
    feet_pos = torch.zeros(n, 4, 3, dtype=torch.float64)
    feet_pos[:, :, 2] = feet_z
    return RobotState(
        pos=torch.tensor([[0.0, 0.0, 0.32], [0.3, 0.4, 0.52], [1.0, 0.0, 0.15]], dtype=torch.float64),
        rot=torch.stack([rot_x(0.0), rot_x(math.pi / 2), rot_x(math.pi)]),
        lin_vel=torch.tensor([[0.0, 0.0, 0.0], [0.0, 0.0, 0.5], [0.0, 0.0, -1.0]]),
        ang_vel=torch.zeros(n, 3),
        q=q,
        qd=torch.zeros(n, J),
        torque=torque,
        feet_contact=feet,
        body_contacts=torch.tensor([0.0, 2.0, 5.0]),
        ground_z=torch.tensor([0.0, 0.35, 0.05], dtype=torch.float64),
        feet_pos=feet_pos,
        foot_radius=torch.full((4,), 0.02, dtype=torch.float64),
    )


def test_upright_cos():
    torch.testing.assert_close(R.upright_cos(make_state()), torch.tensor([1.0, 0.0, -1.0]), atol=1e-6, rtol=0)


def test_vertical_velocity_kernel():
    expected = torch.tensor([1.0, math.exp(-0.25 / 0.25), math.exp(-1.0 / 0.25)])
    torch.testing.assert_close(R.vertical_velocity_kernel(make_state(), 0.25), expected)


def test_torque_l2():
    torch.testing.assert_close(R.torque_l2(make_state()), torch.tensor([0.0, -12.0, -25.0]))


def test_heights_over_feet_and_terrain():
    rs = make_state()
    torch.testing.assert_close(rs.height_over_feet, torch.tensor([0.32, 0.22, 0.10]), atol=1e-6, rtol=0)
    torch.testing.assert_close(rs.height_over_terrain, torch.tensor([0.32, 0.17, 0.10]), atol=1e-6, rtol=0)


def test_base_height_uses_height_over_feet():
    # heights over the feet: 0.32, 0.22, 0.10 (over the terrain env 1 is at 0.17); target 0.32
    expected = torch.tensor([0.0, -(0.1**2), -(0.22**2)])
    torch.testing.assert_close(R.base_height_l2(make_state(), 0.32), expected, atol=1e-6, rtol=0)


def test_body_collisions():
    torch.testing.assert_close(R.body_collisions(make_state()), torch.tensor([0.0, -2.0, -5.0]))


def test_action_rate_l2_on_joint_targets():
    q_star = torch.zeros(2, J)
    prev = torch.zeros(2, J)
    q_star[0] = 1.0
    prev[1, 3] = -0.5
    torch.testing.assert_close(R.action_rate_l2(q_star, prev), torch.tensor([-12.0, -0.25]))


def test_action_rate_term_reads_the_joint_targets():
    ctx = dataclasses.replace(make_ctx(), joint_target=torch.full((3, J), 0.1))
    terms = R.reward_terms(make_state(), ctx, RewardConfig())
    torch.testing.assert_close(terms["action_rate"], torch.full((3,), -12 * 0.01))


def test_horizontal_drift_l2():
    start = torch.tensor([[0.0, 0.0], [0.0, 0.0], [1.0, 0.0]], dtype=torch.float64)
    torch.testing.assert_close(R.horizontal_drift_l2(make_state(), start), torch.tensor([0.0, -0.25, 0.0]))


def test_joint_limit_violation_is_a_penalty():
    out = R.joint_limit_violation(make_state(), LOW, HIGH)
    torch.testing.assert_close(out, torch.tensor([0.0, -0.1, -0.25]), atol=1e-6, rtol=0)
    assert (out <= 0).all()


def test_all_feet_contact():
    torch.testing.assert_close(R.all_feet_contact(make_state()), torch.tensor([1.0, 0.0, 0.0]))


def test_weighted_sum_is_sum_of_w_r_dt():
    rs = make_state()
    cfg = RewardConfig()
    dt = 0.02
    ctx = make_ctx()
    total, terms = R.weighted_rewards(rs, ctx, cfg, dt)
    assert set(terms) == set(R.reward_weights(cfg))
    # env 0 stands upright, still, on four feet at exactly z*: orientation + φ(0) + feet.
    assert total[0].item() == pytest.approx((2.5 * 1.0 + 0.1 * 1.0 + 8.0 * 1.0) * dt)
    # env 2 by hand: cos −1, φ = e^−4, ‖τ‖² 25, height 0.10, 5 contacts, drift 1 m, limits 0.25.
    by_hand = (
        2.5 * -1.0 + 0.1 * math.exp(-4.0) + 0.001 * -25.0 + 40.0 * -(0.22**2) + 1.0 * -5.0
        + 0.01 * -1.0 + 10.0 * -0.25 + 8.0 * 0.0
    ) * dt
    assert total[2].item() == pytest.approx(by_hand, rel=1e-5)
    torch.testing.assert_close(total, torch.stack(list(terms.values())).sum(0))
    assert terms["orientation"][2].item() == pytest.approx(-2.5 * dt)


def test_weights_come_from_config():
    cfg = RewardConfig(orientation=0.0, feet_contact=1.0)
    w = R.reward_weights(cfg)
    assert w["orientation"] == 0.0 and w["feet_contact"] == 1.0 and w["base_height"] == 40.0


def test_goal_set_term_only_with_a_weight():
    in_goal = torch.tensor([True, False, True])
    ctx = dataclasses.replace(make_ctx(), in_goal=in_goal)
    assert "goal_set" not in R.reward_terms(make_state(), ctx, RewardConfig())
    cfg = RewardConfig(goal_set=5.0)
    base, _ = R.weighted_rewards(make_state(), ctx, RewardConfig(), 0.02)
    total, terms = R.weighted_rewards(make_state(), ctx, cfg, 0.02)
    torch.testing.assert_close(terms["goal_set"], torch.tensor([0.1, 0.0, 0.1]))
    torch.testing.assert_close(total - base, torch.tensor([0.1, 0.0, 0.1]))
    with pytest.raises(ValueError, match="in_goal"):
        R.reward_terms(make_state(), make_ctx(), cfg)


def test_bar_ramp_pays_each_centimetre_of_an_upright_stance_under_the_bar():
    """make_state's envs stand 0.32, 0.22 and 0.10 m over their feet."""
    rs = make_state()
    ctx = dataclasses.replace(make_ctx(), stance=torch.tensor([True, True, False]), goal_bar_m=0.37)
    cfg = RewardConfig(bar_ramp=2.0, bar_ramp_width_m=0.1, bar_ramp_over_m=0.0)
    assert "bar_ramp" not in R.reward_terms(rs, ctx, RewardConfig())
    # 5 cm under the bar: half; 15 cm under: nothing; not upright on four feet: nothing
    expected = torch.tensor([0.5, 0.0, 0.0])
    torch.testing.assert_close(R.reward_terms(rs, ctx, cfg)["bar_ramp"], expected)
    over = dataclasses.replace(ctx, goal_bar_m=0.30)  # 2 cm over the bar: all; 8 cm under: a fifth
    torch.testing.assert_close(R.reward_terms(rs, over, cfg)["bar_ramp"], torch.tensor([1.0, 0.2, 0.0]))
    _, weighted = R.weighted_rewards(rs, ctx, cfg, 0.02)
    torch.testing.assert_close(weighted["bar_ramp"], 2.0 * expected * 0.02)
    margin = dataclasses.replace(cfg, bar_ramp_over_m=0.05)  # the ramp tops out 5 cm over the bar
    torch.testing.assert_close(R.reward_terms(rs, ctx, margin)["bar_ramp"], torch.tensor([0.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="bar_ramp"):
        R.reward_terms(rs, make_ctx(), cfg)


def test_feet_under_hips_is_the_squared_horizontal_offset_of_the_feet_from_their_roots():
    """Feet straight under their leg roots cost nothing in any trunk attitude; a foot 0.1 m out
    horizontally costs 0.01 m²; vertical offsets and stances off four feet cost nothing."""
    roots = torch.tensor([[0.2, -0.13, 0.0], [0.2, 0.13, 0.0], [-0.2, -0.13, 0.0], [-0.2, 0.13, 0.0]])
    rs = make_state()
    tilted = rot_x(0.3)
    rot = torch.stack([tilted, tilted, tilted])
    feet = rs.pos[:, None, :] + torch.einsum("ij,fj->fi", tilted.double(), roots.double())[None]
    feet = feet - torch.tensor([0.0, 0.0, 0.3], dtype=torch.float64)  # straight down
    feet[1, 2, 0] += 0.1  # one foot 0.1 m forward
    feet[2, 0, 1] += 0.2  # a foot out, but env 2 is not in a stance
    rs = dataclasses.replace(rs, rot=rot, feet_pos=feet)
    ctx = dataclasses.replace(make_ctx(), stance=torch.tensor([True, True, False]), leg_roots_m=roots)
    cfg = RewardConfig(feet_under_hips=5.0)
    assert "feet_under_hips" not in R.reward_terms(rs, ctx, RewardConfig())
    expected = torch.tensor([0.0, -0.01, 0.0])
    torch.testing.assert_close(R.reward_terms(rs, ctx, cfg)["feet_under_hips"], expected)
    _, weighted = R.weighted_rewards(rs, ctx, cfg, 0.02)
    torch.testing.assert_close(weighted["feet_under_hips"], 5.0 * expected * 0.02)
    with pytest.raises(ValueError, match="feet_under_hips"):
        R.reward_terms(rs, make_ctx(), cfg)
