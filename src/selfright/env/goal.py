"""The goal set (seed §IV) and the success bookkeeping of an episode."""

from __future__ import annotations

import math

import torch

from selfright.config import GoalConfig
from selfright.env.robot_state import RobotState


def body_height(rs: RobotState, cfg: GoalConfig) -> torch.Tensor:
    """(n,) the goal set's body height (m): ``RobotState.height_over_feet``, or with
    ``cfg.height_ref = "terrain"`` (for comparison) ``RobotState.height_over_terrain``."""
    return rs.height_over_terrain if cfg.height_ref == "terrain" else rs.height_over_feet


def goal_height_m(cfg: GoalConfig, leg_length_m: float) -> float:
    """The goal set's height bar: ``height_fraction`` × the fully extended leg length (m)."""
    return cfg.height_fraction * leg_length_m


def upright(roll: torch.Tensor, pitch: torch.Tensor, cfg: GoalConfig) -> torch.Tensor:
    """(n,) bool: roll and pitch (rad) both within the goal set's tilt tolerance."""
    tilt = math.radians(cfg.max_tilt_deg)
    return (roll.abs() <= tilt) & (pitch.abs() <= tilt)


def upright_on_four_feet(roll: torch.Tensor, pitch: torch.Tensor, feet_contact: torch.Tensor, cfg: GoalConfig) -> torch.Tensor:
    """(n,) bool: ``upright`` with all four feet down ((n, 4) ``feet_contact``): the goal set
    but for its height bar."""
    return upright(roll, pitch, cfg) & feet_contact.all(dim=-1)


def in_goal_set(
    roll: torch.Tensor,
    pitch: torch.Tensor,
    feet_contact: torch.Tensor,
    height: torch.Tensor,
    cfg: GoalConfig,
    leg_length_m: float,
) -> torch.Tensor:
    """Whether each env is in the goal set.

    Args:
        roll, pitch: (n,) trunk roll and pitch relative to gravity (rad).
        feet_contact: (n, 4) bool, each foot touching the ground.
        height: (n,) body height (m), ``body_height``.

    Returns:
        (n,) bool: |roll| ≤ tilt, |pitch| ≤ tilt, all feet down, height ≥ fraction × leg length.
    """
    return upright_on_four_feet(roll, pitch, feet_contact, cfg) & (height >= goal_height_m(cfg, leg_length_m))


def robot_in_goal_set(rs: RobotState, cfg: GoalConfig, leg_length_m: float) -> torch.Tensor:
    """(n,) bool: ``in_goal_set`` of the robot states ``rs`` (body height per ``cfg.height_ref``)."""
    return in_goal_set(rs.roll, rs.pitch, rs.feet_contact, body_height(rs, cfg), cfg, leg_length_m)


class GoalTracker:
    """Tracks, per env, the current uninterrupted stay in the goal set.

    An episode succeeds once a stay has lasted ``hold_steps`` control steps; its TTR is the
    time at which that stay began and its DTR the x-y displacement at that moment.
    """

    def __init__(self, num_envs: int, hold_steps: int):
        self.hold_steps = hold_steps
        self.streak = torch.zeros(num_envs, dtype=torch.long)
        self.streak_start_step = torch.zeros(num_envs, dtype=torch.long)
        self.streak_start_xy = torch.zeros(num_envs, 2, dtype=torch.float64)

    def reset(self, ids: torch.Tensor) -> None:
        self.streak[ids] = 0

    def update(self, ids: torch.Tensor, in_goal: torch.Tensor, step: torch.Tensor, xy: torch.Tensor) -> torch.Tensor:
        """Record one control step of envs ``ids`` (k,).

        Args:
            in_goal: (k,) bool, in the goal set after this step.
            step: (k,) control steps since policy start (the state's time is step · dt);
                a stay starts at the first state found in the goal set.
            xy: (k, 2) trunk x-y now (m).

        Returns (k,) bool: the env has just completed the hold (success decided now).
        """
        streak = self.streak[ids]
        entering = in_goal & (streak == 0)
        self.streak_start_step[ids] = torch.where(entering, step, self.streak_start_step[ids])
        self.streak_start_xy[ids] = torch.where(entering[:, None], xy.to(torch.float64), self.streak_start_xy[ids])
        streak = torch.where(in_goal, streak + 1, torch.zeros_like(streak))
        self.streak[ids] = streak
        return streak == self.hold_steps
