"""The batched self-righting environment: fall protocol resets, PD action mapping, goal-set
bookkeeping and per-episode metrics. Evaluation drives it directly; training wraps it
with rewards and domain randomisation (``selfright.train.vecenv``).

Every slot (env) runs on its own ``MjModel`` (shared between slots of the same world unless
randomised) and its own state row; one ``BatchStepper`` call advances any subset of slots.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import torch

from selfright.config import BenchmarkConfig
from selfright.env.fall import SelfCollisionChecker, initial_qpos
from selfright.env.goal import GoalTracker, robot_in_goal_set
from selfright.env.observations import privileged_obs, scan_points, student_obs
from selfright.env.robot_state import RobotState, decode
from selfright.env.world import World
from selfright.robots import get_robot
from selfright.sim.batch import BatchStepper, sensor_layout, state_layout
from selfright.terrain.heightfield import sample_heights

EDGE_MARGIN_M = 0.5
"""An episode fails once the trunk is this close to the tile's edge (m)."""


@dataclass(frozen=True)
class SettledStarts:
    """k falls after the 2 s passive settle, not yet in any slot."""

    state: np.ndarray
    """(k, S) state rows (time, qpos, qvel, ...; ``sim.batch.state_layout``)."""
    sens: np.ndarray
    """(k, nsensordata) sensor rows at the end of the settle."""
    diverged: np.ndarray
    """(k,) bool, the settle diverged (the row holds the finite pre-drop state)."""


@dataclass
class StepOutput:
    """Result of one control step for the stepped slots ``ids``."""

    ids: np.ndarray
    """(k,) slot indices stepped."""
    state: RobotState
    """Robot quantities after the step, rows aligned with ``ids``."""
    in_goal: torch.Tensor
    """(k,) bool, in the goal set now."""
    succeeded: torch.Tensor
    """(k,) bool, the hold was completed at this step (success decided)."""
    failed: torch.Tensor
    """(k,) bool, diverged or left the tile (episode over, unsuccessful)."""
    timeout: torch.Tensor
    """(k,) bool, reached the episode limit without success."""
    diverged: torch.Tensor
    """(k,) bool, physics diverged at this step."""

    @property
    def done(self) -> torch.Tensor:
        return self.succeeded | self.failed | self.timeout


class RecoveryEnv:
    """``num_envs`` slots over a list of worlds (all of one heightfield size)."""

    def __init__(self, cfg: BenchmarkConfig, worlds: list[World], num_envs: int, threads: int | None = None):
        if not worlds:
            raise ValueError("need at least one world")
        self.cfg = cfg
        self.robot = get_robot(cfg.robot.name)
        self.worlds = worlds
        self.num_envs = num_envs
        template = worlds[0].model
        self.stepper = BatchStepper(template, cfg.sim.threads if threads is None else threads)
        self.sl = state_layout(template)
        self.so = sensor_layout(template, self.robot)
        self.foot_radius = np.array([template.geom_size[template.geom(g).id, 0] for g in self.robot.foot_geoms])
        """(F,) radius of each foot sphere (m)."""
        self.checker = SelfCollisionChecker(self.robot)
        self.heights = np.stack([w.tile.heights for w in worlds])
        self.res = cfg.terrain.resolution_m
        self.half_size = cfg.terrain.tile_size_m / 2
        self.control_dt = cfg.sim.control_dt_s
        self.episode_steps = int(round(cfg.goal.episode_s / self.control_dt))
        self.settle_steps = int(round(cfg.fall.settle_s / cfg.sim.timestep_s))
        self.nominal = torch.tensor(self.robot.nominal_pose, dtype=torch.float32)
        self._ref_pose = self.robot.reference_pose(cfg.action.reference)
        """(J,) joint angles of action 0, or None (``current``: the angles at each step)."""
        self._low = self.robot.joint_low
        self._high = self.robot.joint_high
        nj = self.robot.num_joints
        self.world_idx = np.zeros(num_envs, dtype=np.int64)
        self.models: list[mujoco.MjModel] = [template] * num_envs
        self.state = np.zeros((num_envs, self.sl.size))
        self.sens = np.zeros((num_envs, template.nsensordata))
        self.prev_action = torch.zeros(num_envs, nj)
        self.joint_target = torch.zeros(num_envs, nj)
        """(n, J) PD joint targets q* of each slot's latest control step (rad); at an episode's
        start, its joint angles (what the settle's PD servos held)."""
        self.step_count = torch.zeros(num_envs, dtype=torch.long)
        self.start_xy = torch.zeros(num_envs, 2, dtype=torch.float64)
        self.energy = torch.zeros(num_envs, dtype=torch.float64)
        self.peak_ang_speed = torch.zeros(num_envs)
        self.diverged = torch.zeros(num_envs, dtype=torch.bool)
        self.factors = torch.ones(num_envs, 3)
        self.friction = torch.ones(num_envs)
        self.goal = GoalTracker(num_envs, int(round(cfg.goal.hold_s / self.control_dt)))
        self._all = np.arange(num_envs)
        self.last_ctrl = np.zeros((0, nj))
        """PD targets (k, J) applied by the latest ``step`` (the rows of its ``ids``)."""

    # ------------------------------------------------------------------ resets
    def reset(
        self,
        ids: np.ndarray,
        world_idx: np.ndarray,
        rngs: list[np.random.Generator],
        models: list[mujoco.MjModel] | None = None,
    ) -> None:
        """Start new episodes in slots ``ids``: fall protocol, drop, passive settling.

        Args:
            ids: (k,) slots.
            world_idx: (k,) world of each new episode.
            rngs: k generators, one per episode (all of its randomness comes from it).
            models: optional per-slot models (domain randomisation); default: the world's.
        """
        if len(ids) == 0:
            return
        models = models if models is not None else [self.worlds[w].model for w in world_idx]
        self.begin(ids, world_idx, models, self.settle(world_idx, rngs, models))

    def settle(
        self, world_idx: np.ndarray, rngs: list[np.random.Generator], models: list[mujoco.MjModel]
    ) -> SettledStarts:
        """Draw k falls (seed's protocol) and let them settle passively, in one batched rollout;
        touches no slot. ``begin`` puts them into slots (now or later: training prepares
        the next episodes' starts ahead, in large batches)."""
        fall, terrain = self.cfg.fall, self.cfg.terrain
        nq = self.sl.qpos_joints.stop - 1
        init = np.zeros((len(world_idx), self.sl.size))
        for k, (w, rng) in enumerate(zip(world_idx, rngs)):
            world = self.worlds[w]
            init[k, 1 : 1 + nq] = initial_qpos(rng, self.robot, self.checker, world.tile, fall, terrain, world.fixed_spawn_y)
        return self.hold_rollout(models, init, self.settle_steps)

    def hold_rollout(self, models: list[mujoco.MjModel], init: np.ndarray, nstep: int) -> SettledStarts:
        """Roll (k, S) ``init`` states out ``nstep`` physics steps, each holding its own joint
        angles as PD targets, to where a fall's settle ends (``FallConfig.settle_s``); a row that
        diverges or ends at another time keeps its finite start and is flagged diverged."""
        states, sens = self.stepper.step(models, init, init[:, self.sl.qpos_joints], nstep)
        final = states[:, -1]
        bad = ~np.isfinite(final).all(axis=1) | (np.abs(final[:, 0] - self.cfg.fall.settle_s) > 1e-6)
        final[bad] = init[bad]  # keep a finite state; the episode is flagged diverged in begin
        return SettledStarts(state=final, sens=sens[:, -1], diverged=bad)

    def begin(
        self, ids: np.ndarray, world_idx: np.ndarray, models: list[mujoco.MjModel], starts: SettledStarts
    ) -> None:
        """Start episodes in slots ``ids`` from settled falls (rows of ``starts`` aligned with
        ``ids``), each on its world ``world_idx`` and model (the one it settled on)."""
        ids = np.asarray(ids, dtype=np.int64)
        for k, i in enumerate(ids):
            self.world_idx[i] = world_idx[k]
            self.models[i] = models[k]
            self.friction[i] = float(self.worlds[world_idx[k]].context.friction)
        self.state[ids] = starts.state
        self.sens[ids] = starts.sens
        self._last = None
        t = torch.from_numpy(ids)
        self.diverged[t] = torch.from_numpy(starts.diverged)
        self.start_xy[t] = torch.from_numpy(starts.state[:, 1:3].copy())
        self.prev_action[t] = 0.0
        self.joint_target[t] = torch.from_numpy(starts.state[:, self.sl.qpos_joints].astype(np.float32))
        self.step_count[t] = 0
        self.energy[t] = 0.0
        self.peak_ang_speed[t] = 0.0
        self.goal.reset(t)

    # -------------------------------------------------------------- stepping
    def ground_height(self, ids: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """(k,) ground height under points ``xy`` (k, 2) on the tiles of slots ``ids``."""
        return sample_heights(self.heights, self.world_idx[ids], xy, self.res)

    def feet_xyz(self, ids: np.ndarray) -> np.ndarray:
        """(k, F, 3) world positions of the feet of slots ``ids`` (their geoms' centres)."""
        return self.sens[ids, self.so.foot_pos].reshape(len(ids), -1, 3)

    def robot_state(self, ids: np.ndarray) -> RobotState:
        st = self.state[ids]
        return decode(st, self.sens[ids], self.ground_height(ids, st[:, 1:3]), self.sl, self.so, self.foot_radius)

    def _clip(self, actions: torch.Tensor) -> torch.Tensor:
        return actions.detach().float().clamp(-self.cfg.action.clip, self.cfg.action.clip)

    def _targets(self, state: np.ndarray, clipped: torch.Tensor) -> np.ndarray:
        """PD joint targets (k, J): reference + scale · clipped action, within joint limits
        (reference: the pose of ``ActionConfig.reference``, ``RobotSpec.reference_pose``, or for
        ``current`` the angles at the start of the step)."""
        ref = state[:, self.sl.qpos_joints] if self._ref_pose is None else self._ref_pose
        scale = self.cfg.action.scale_rad
        return np.clip(ref + scale * clipped.double().numpy(), self._low, self._high)

    def step(self, actions: torch.Tensor, ids: np.ndarray | None = None) -> StepOutput:
        """Apply ``actions`` (k, J) to slots ``ids`` (default: all) for one control step."""
        ids = np.arange(self.num_envs) if ids is None else np.asarray(ids, dtype=np.int64)
        full = len(ids) == self.num_envs and bool((ids == self._all).all())
        # Every slot in order (training, benchmarks): slices are views, fancy indexing copies.
        t = slice(None) if full else torch.from_numpy(ids)
        rows = slice(None) if full else ids
        clipped = self._clip(actions)
        start = self.state[rows].copy() if full else self.state[rows]
        ctrl = self._targets(start, clipped)
        self.last_ctrl = ctrl
        sub = self.cfg.sim.control_substeps
        models = self.models if full else [self.models[i] for i in ids]
        states, sens = self.stepper.step(models, start, ctrl, sub)
        final = states[:, -1]
        expected_t = start[:, 0] + sub * self.cfg.sim.timestep_s
        bad = ~np.isfinite(states).all(axis=(1, 2)) | (np.abs(final[:, 0] - expected_t) > 1e-6)
        # Mechanical energy drawn by the motors: Σ_substeps Σ_j |τ_j q̇_j| dt.
        tau = sens[:, :, self.so.actuator_force]
        qd = states[:, :, self.sl.qvel_joints]
        power = np.nan_to_num(np.abs(tau * qd).sum(axis=(1, 2)))
        ang = np.nan_to_num(np.linalg.norm(states[:, :, self.sl.ang_vel], axis=2).max(axis=1))
        if bad.any():
            final = np.where(bad[:, None], start, final)
            sens_last = np.where(bad[:, None], self.sens[rows], sens[:, -1])
        else:
            sens_last = sens[:, -1]
        self.state[rows] = final
        self.sens[rows] = sens_last
        self.energy[t] += torch.from_numpy(power * self.cfg.sim.timestep_s)
        self.peak_ang_speed[t] = torch.maximum(self.peak_ang_speed[t], torch.from_numpy(ang).float())
        div = torch.from_numpy(bad)
        self.diverged[t] |= div
        self.step_count[t] += 1
        self.prev_action[t] = clipped
        self.joint_target[t] = torch.from_numpy(ctrl.astype(np.float32))

        rs = self.robot_state(ids)
        self._last = (ids, rs)
        goal = robot_in_goal_set(rs, self.cfg.goal, self.robot.leg_length_m)
        goal &= ~self.diverged[t]
        succeeded = self.goal.update(t, goal, self.step_count[t], rs.pos[:, :2])
        off_tile = (rs.pos[:, :2].abs() > self.half_size - EDGE_MARGIN_M).any(dim=1)
        failed = (self.diverged[t] | off_tile) & ~succeeded
        timeout = (self.step_count[t] >= self.episode_steps) & ~succeeded & ~failed
        return StepOutput(ids=ids, state=rs, in_goal=goal, succeeded=succeeded, failed=failed, timeout=timeout, diverged=div)

    # ---------------------------------------------------------- observations
    def observe(self, ids: np.ndarray | None = None, groups: tuple[str, ...] = ("student", "teacher")) -> dict[str, torch.Tensor]:
        """Observation groups ``student`` (k, 6 + 3J) and ``teacher`` (k, 18 + 3J + S) for slots
        ``ids``; only the ``groups`` asked for are computed (the teacher's scan costs time)."""
        ids = np.arange(self.num_envs) if ids is None else np.asarray(ids, dtype=np.int64)
        t = torch.from_numpy(ids)
        last = getattr(self, "_last", None)
        same = last is not None and len(last[0]) == len(ids) and np.array_equal(last[0], ids)
        rs = last[1] if same else self.robot_state(ids)
        student = student_obs(rs, self.nominal, self.prev_action[t])
        if "teacher" not in groups:
            return {"student": student}
        pts = scan_points(rs)
        k, s = pts.shape[:2]
        scan = sample_heights(self.heights, np.repeat(self.world_idx[ids], s), pts.reshape(-1, 2), self.res)
        slope = torch.tensor([self.worlds[w].cell.slope_pct for w in self.world_idx[ids]], dtype=torch.float32)
        priv = privileged_obs(rs, slope, self.friction[t], torch.from_numpy(scan.reshape(k, s)), self.factors[t])
        return {"student": student, "teacher": torch.cat([student, priv], dim=-1)}

    def metrics(self, ids: np.ndarray) -> dict[str, np.ndarray]:
        """Per-episode bookkeeping of slots ``ids``: TTR, DTR (if successful), energy, peak ω."""
        t = torch.from_numpy(np.asarray(ids, dtype=np.int64))
        ttr = self.goal.streak_start_step[t].double() * self.control_dt
        dtr = (self.goal.streak_start_xy[t] - self.start_xy[t]).norm(dim=1)
        return {
            "ttr_s": ttr.numpy(),
            "dtr_m": dtr.numpy(),
            "energy_j": self.energy[t].numpy(),
            "peak_ang_speed": self.peak_ang_speed[t].double().numpy(),
            "diverged": self.diverged[t].numpy(),
        }

    def close(self) -> None:
        self.stepper.close()

