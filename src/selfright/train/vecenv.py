"""rsl_rl ``VecEnv`` adapter over ``RecoveryEnv`` for training.

Thin on purpose: rewards come from ``env.rewards``, domain randomisation from
``env.randomization``, observations from ``RecoveryEnv.observe``. This module only adds
automatic resets, episode bookkeeping and the extras rsl_rl reads:

- ``extras["time_outs"]`` (n,) bool: the episode hit the time limit (bootstrapped by PPO);
- ``extras["log"]``: per step, every weighted reward term averaged over envs
  (``Reward/<term>``); when episodes end, their per-episode sums (``Episode_Reward/<term>``)
  and outcome rates (``Episode/...``).

``Episode/success_rate`` is measured under the rollout's exploration noise: one foot lifting
for one control step breaks the 1 s hold, so it reads far below the deterministic policy's
success (0.00 in training while ``selfright evaluate`` measured 66 %, flat teacher at 3.3 M
steps). ``Metrics/in_goal`` (fraction of env steps in the goal set) tracks progress better;
judge policies with ``selfright evaluate``.

Training episodes last ``EpisodeConfig.episode_s`` (10 s) after the fall protocol; they end
early only when the physics diverges (terminal) or the robot leaves the tile (a time-out:
bootstrapped, see ``EpisodeConfig.off_tile_is_timeout``), not on success, so the policy
learns to keep standing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np
import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from selfright.config import BenchmarkConfig, to_dict
from selfright.env.goal import body_height, goal_height_m, upright, upright_on_four_feet
from selfright.env.observations import sensor_noise_std
from selfright.env.randomization import EpisodeFactors, ModelRandomizer, sample_factors
from selfright.env.recovery_env import RecoveryEnv
from selfright.env.rewards import RewardContext, reward_weights, weighted_rewards
from selfright.env.world import World
from selfright.policies.actor import group_dim
from selfright.policies.history import ObsHistory
from selfright.train.config import TrainConfig, student_group
from selfright.train.starts import EpisodeDraw, PreparedStarts

if TYPE_CHECKING:
    from selfright.env.robot_state import RobotState

SENSOR_NOISE_STREAM = 0x5E45
"""Appended to the run's seed to key the sensor noise's generator (``RecoveryVecEnv.noise_rng``)."""


class RecoveryVecEnv(VecEnv):
    """``num_envs`` auto-resetting training episodes over ``worlds``.

    Args:
        cfg: benchmark configuration (terrain, robot, sim, fall protocol, goal set).
        train: training configuration (rewards, randomisation, episode length).
        worlds: the training context's worlds; each episode draws one uniformly.
        num_envs: parallel episodes.
        seed: seeds every episode (fall, world choice, randomisation) through one generator
            (an int or a tuple of ints, e.g. (run seed, start iteration)).
        threads: physics worker threads.
        device: torch device the observations, rewards and dones are returned on (the
            networks' device; the simulation and its bookkeeping stay on the CPU).

    With ``RandomizationConfig.sensor_noise`` > 0 the ``student`` group (and the student's
    history frames) read noisy sensors, from a generator of their own; the ``teacher`` group
    stays exact.
    """

    def __init__(
        self,
        cfg: BenchmarkConfig,
        train: TrainConfig,
        worlds: list[World],
        num_envs: int,
        seed: int | tuple[int, ...],
        threads: int = 1,
        device: str = "cpu",
    ):
        self.env = RecoveryEnv(cfg, worlds, num_envs, threads=threads)
        self.train_cfg = train
        self.num_envs = num_envs
        self.num_actions = self.env.robot.num_joints
        self.device = device
        self.cfg = {"benchmark": to_dict(cfg), "train": to_dict(train)}
        self.dt = self.env.control_dt
        self.max_episode_length = int(round(train.episode.episode_s / self.dt))
        self.episode_length_buf = torch.zeros(num_envs, dtype=torch.long)
        self.rng = np.random.default_rng(seed)
        noise = train.randomization.active_sensor_noise
        self.sensor_noise_std = noise * sensor_noise_std(self.env.robot.num_joints) if noise > 0 else None
        """(6 + 3J,) std of the sensor noise on each ``student`` column; None = exact sensors."""
        self.noise_rng = np.random.default_rng([*np.atleast_1d(seed).tolist(), SENSOR_NOISE_STREAM])
        """The sensor noise's own generator: turning the noise on leaves every episode's draws
        (worlds, falls, factors) as they were."""
        self.randomizer = ModelRandomizer(worlds[0].model, self.env.robot) if train.randomization.enabled else None
        robot = self.env.robot
        self.joint_low = torch.tensor(robot.joint_low, dtype=torch.float32)
        self.joint_high = torch.tensor(robot.joint_high, dtype=torch.float32)
        target = train.reward.target_height_m
        self.target_height_m = robot.stand_height_m if target is None else target
        """z* of the base-height term, a height over the feet (m)."""
        self.term_names = tuple(reward_weights(train.reward))
        self.episode_sums = {name: torch.zeros(num_envs) for name in self.term_names}
        self.ever_succeeded = torch.zeros(num_envs, dtype=torch.bool)
        ep = train.episode
        self.curriculum = ep.curriculum and len(worlds) > 1
        self.level = torch.zeros(num_envs, dtype=torch.long)
        """Curriculum level (index into ``worlds``) of each slot's next episode."""
        self.window = max(1, int(round(ep.curriculum_window_s / self.dt)))
        self.tail_goal_steps = torch.zeros(num_envs, dtype=torch.long)
        """In-goal control steps within the final ``window`` steps of the current episode."""
        self.low_stance_steps = int(round(ep.terminate_low_stance_s / self.dt))
        """Control steps of low stance that end an episode (``terminate_low_stance_s``; 0 = never)."""
        self.low_streak = torch.zeros(num_envs, dtype=torch.long)
        """Control steps each slot has stood upright on four feet under the goal bar without a
        break (with ``low_stance_leaky``: the leaky count of ``_low_stance_ended``)."""
        self.goal_bar_m = goal_height_m(cfg.goal, robot.leg_length_m)
        if train.reward.feet_under_hips and robot.leg_roots_m is None:
            raise ValueError(f"the feet_under_hips reward term needs the leg roots of robot {robot.name!r} "
                             "(RobotSpec.leg_roots_m)")
        self.leg_roots_m = None if robot.leg_roots_m is None else torch.as_tensor(robot.leg_roots_m)
        frames = train.distillation.student_history
        self.student_frames = ObsHistory(frames, group_dim("student"), num_envs) if frames > 1 else None
        """The last ``student_history`` student observations of each slot (group
        ``student_group(frames)``), for a student that reads a short history."""
        self.prepare_starts = ep.prepare_starts
        self.next_start = PreparedStarts(num_envs, self.env.sl.size, self.env.sens.shape[1])
        """Each slot's settled next episode start, drawn ahead in batches (``prepare_starts``)."""
        self.reset_all()

    # ------------------------------------------------------------------ resets
    def reset_all(self) -> TensorDict:
        """Start fresh episodes in every slot (prepared starts are dropped); returns the
        observations."""
        ids = np.arange(self.num_envs)
        self.next_start.ready[:] = False
        self._begin(ids, self._draw(ids))
        self._obs = self._observe()
        return self._obs

    def _reset(self, ids: np.ndarray) -> None:
        """Start new episodes in slots ``ids`` (fall protocol + settle, fresh world and factors).

        With ``EpisodeConfig.prepare_starts`` the settled falls come from ``next_start``: when a
        finishing slot has none ready, the next start of *every* slot without one is drawn and
        settled in one batched rollout (about one batch of ``num_envs`` per episode length,
        instead of a 2 s rollout over the 1–3 slots that end at each control step, which
        leaves most physics threads idle)."""
        if len(ids) == 0:
            return
        if not self.prepare_starts:
            self._begin(ids, self._draw(ids))
            return
        t = torch.from_numpy(ids)
        if self.curriculum:  # a prepared start on another level than the slot's is stale
            stale = self.next_start.ready[ids] & (self.next_start.world[ids] != self.level[t].numpy())
            self.next_start.ready[ids[stale]] = False
        if not self.next_start.ready[ids].all():
            todo = np.flatnonzero(~self.next_start.ready)
            self.next_start.put(todo, self._draw(todo))
        self._begin(ids, self.next_start.take(ids))

    def _draw(self, slots: np.ndarray) -> EpisodeDraw:
        """Draw and settle the next episodes of ``slots``: world (curriculum level or uniform),
        fall, randomisation factors."""
        k = len(slots)
        env = self.env
        if self.curriculum:
            world_idx = self.level[torch.from_numpy(slots)].numpy().copy()
        else:
            world_idx = self.rng.integers(len(env.worlds), size=k)
        rngs = self.rng.spawn(k)
        f = sample_factors(k, self.train_cfg.randomization, self.rng) if self.randomizer is not None else None
        models = self._models(world_idx, f)
        settled = env.settle(world_idx, rngs, models)
        return EpisodeDraw(world_idx, f, models, settled)

    def _models(self, world_idx: np.ndarray, f: EpisodeFactors | None) -> list[mujoco.MjModel]:
        """The episodes' models: randomised copies of their worlds' models, or those models."""
        bases = [self.env.worlds[w].model for w in world_idx]
        return bases if f is None else self.randomizer.models(bases, f)

    def _begin(self, ids: np.ndarray, draw: EpisodeDraw) -> None:
        """Put drawn starts into slots ``ids`` and clear the slots' episode bookkeeping."""
        env = self.env
        models = draw.models if draw.models is not None else self._models(draw.world_idx, draw.factors)
        env.begin(ids, draw.world_idx, models, draw.settled)  # also sets the worlds' friction
        t = torch.from_numpy(ids)
        if draw.factors is not None:
            env.factors[t] = draw.factors.as_tensor()
            env.friction[t] = torch.from_numpy(draw.factors.friction).float()
        else:
            env.factors[t] = 1.0
        self.episode_length_buf[t] = 0
        self.tail_goal_steps[t] = 0
        self.low_streak[t] = 0
        if self.student_frames is not None:
            self.student_frames.reset(ids)
        self.ever_succeeded[t] = False
        for s in self.episode_sums.values():
            s[t] = 0.0

    # ------------------------------------------------------------ observations
    def _observe(self) -> TensorDict:
        """The observation groups of the current states. The sensor noise
        (``RandomizationConfig.sensor_noise``) goes onto the ``student`` group, and so into the
        student's history frames."""
        groups = self.env.observe()
        if self.sensor_noise_std is not None:
            z = self.noise_rng.standard_normal(tuple(groups["student"].shape), dtype=np.float32)
            groups["student"] = groups["student"] + self.sensor_noise_std * torch.from_numpy(z)
        if self.student_frames is not None:
            groups[student_group(self.student_frames.frames)] = self.student_frames.push(np.arange(self.num_envs), groups["student"])
        return TensorDict(groups, batch_size=[self.num_envs]).to(self.device)

    def get_observations(self) -> TensorDict:
        """Observation groups ``student`` (n, 42) and ``teacher`` (n, 79) of the current states,
        and ``student_history`` (n, 42 H) with a student history of H > 1 frames."""
        return self._obs

    # -------------------------------------------------------------- stepping
    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        """One control step of every env with actions (n, J); done envs restart at once.

        Returns observations (after any reset), rewards (n,), dones (n,) and extras.
        """
        env = self.env
        prev_target = env.joint_target.clone()
        out = env.step(actions.detach().cpu())
        diverged = env.diverged
        left_tile = out.failed & ~diverged
        ctx = RewardContext(
            joint_target=env.joint_target,  # the targets just applied
            prev_joint_target=prev_target,
            start_xy=env.start_xy,
            joint_low=self.joint_low,
            joint_high=self.joint_high,
            target_height_m=self.target_height_m,
            in_goal=out.in_goal,
            stance=(upright_on_four_feet(out.state.roll, out.state.pitch, out.state.feet_contact, self.env.cfg.goal)
                    if self.train_cfg.reward.bar_ramp or self.train_cfg.reward.feet_under_hips else None),
            goal_bar_m=self.goal_bar_m,
            leg_roots_m=self.leg_roots_m,
        )
        reward, terms = weighted_rewards(out.state, ctx, self.train_cfg.reward, self.dt)

        self.episode_length_buf += 1
        self.ever_succeeded |= out.succeeded
        if self.curriculum:
            in_tail = self.episode_length_buf > self.max_episode_length - self.window
            self.tail_goal_steps += (out.in_goal & in_tail).long()
        terminated = out.failed & diverged
        ep = self.train_cfg.episode
        if not ep.off_tile_is_timeout:
            terminated |= left_tile
        low_stance = self._low_stance_ended(out.state, out.in_goal)
        terminated |= low_stance
        time_out = ((self.episode_length_buf >= self.max_episode_length) | left_tile) & ~terminated
        dones = terminated | time_out

        log: dict[str, float | torch.Tensor] = {f"Reward/{n}": v.mean() for n, v in terms.items()}
        log["Reward/total"] = reward.mean()
        log["Metrics/in_goal"] = out.in_goal.float().mean()
        log["Metrics/upright_cos"] = out.state.up_z.float().mean()
        for name, value in terms.items():
            self.episode_sums[name] += value
        done_ids = dones.nonzero(as_tuple=False).flatten()
        if len(done_ids) > 0:
            in_goal = self._ended_in_goal(done_ids)
            for name in self.term_names:
                log[f"Episode_Reward/{name}"] = self.episode_sums[name][done_ids].mean()
            log["Episode/success_rate"] = self.ever_succeeded[done_ids].float().mean()
            log["Episode/failure_rate"] = out.failed[done_ids].float().mean()
            log["Episode/left_tile_rate"] = left_tile[done_ids].float().mean()
            if self.low_stance_steps > 0:
                log["Episode/low_stance_end_rate"] = low_stance[done_ids].float().mean()
            log["Episode/length_s"] = self.episode_length_buf[done_ids].float().mean() * self.dt
            if self.curriculum:
                self._update_levels(done_ids, in_goal, left_tile[done_ids])
                log["Curriculum/mean_level"] = self.level.float().mean()
                log["Curriculum/at_top"] = (self.level == len(self.env.worlds) - 1).float().mean()
            self._reset(done_ids.numpy())
        self._obs = self._observe()
        extras = {"time_outs": time_out.to(self.device), "log": log}
        return self._obs, reward.to(self.device), dones.to(self.device), extras

    def _low_stance_ended(self, state: RobotState, in_goal: torch.Tensor) -> torch.Tensor:
        """(n,) bool: the robot has now stood upright on four feet under the goal bar for
        ``EpisodeConfig.terminate_low_stance_s`` without a break (all False when off). With
        ``low_stance_leaky`` three feet count too, and a step that is neither such a stance nor
        in the goal set (``in_goal``, (n,)) takes one step off the count instead of clearing it."""
        if self.low_stance_steps <= 0:
            return torch.zeros(self.num_envs, dtype=torch.bool)
        ep = self.train_cfg.episode
        leaky = ep.low_stance_leaky
        feet = state.feet_contact.sum(dim=-1) >= (3 if leaky else 4)
        under = body_height(state, self.env.cfg.goal) < self.goal_bar_m
        low = upright(state.roll, state.pitch, self.env.cfg.goal) & feet & under
        other = (self.low_streak - 1).clamp(min=0) if leaky else torch.zeros_like(self.low_streak)
        streak = torch.where(low, self.low_streak + 1, other)
        self.low_streak = torch.where(in_goal, torch.zeros_like(streak), streak)
        return self.low_streak >= self.low_stance_steps

    def _ended_in_goal(self, ids: torch.Tensor) -> torch.Tensor:
        """Whether the finished episodes in slots ``ids`` spent at least half of their final
        ``window`` steps in the goal set: what the curriculum calls success."""
        return self.tail_goal_steps[ids] * 2 >= self.window

    def _update_levels(self, ids: torch.Tensor, in_goal: torch.Tensor, left_tile: torch.Tensor) -> None:
        """Promote slots whose finished episode ended in the goal set (``in_goal``, per id:
        ``_ended_in_goal``); demote those that spent none of their final window there or left
        the tile."""
        up = in_goal & ~left_tile
        # never together with up: up needs tail ≥ 1, on the tile
        down = ((self.tail_goal_steps[ids] == 0) & ~in_goal) | left_tile
        step = up.long() - down.long()
        self.level[ids] = (self.level[ids] + step).clamp(0, len(self.env.worlds) - 1)

    def restore_curriculum(self, levels: list[int] | None) -> None:
        """Set the slots' curriculum levels to those saved with a checkpoint (``None`` or no
        curriculum: nothing to do). A different slot count reuses the saved levels in turn; the
        episodes already running keep theirs, and the next ones start at the restored levels."""
        if not self.curriculum or not levels:
            return
        saved = torch.as_tensor(levels, dtype=torch.long).clamp(0, len(self.env.worlds) - 1)
        self.level[:] = saved[torch.arange(self.num_envs) % len(saved)]

    def close(self) -> None:
        self.env.close()
