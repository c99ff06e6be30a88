"""Policies built from other policies, for analysis (none ships): one that samples its
actions from its training noise instead of acting with the mean, an ensemble acting with the
mean of its members' actions, one whose actions are low-passed, one whose joints are
blended to a fixed pose once upright (the hips to 0, or a whole stance), one that holds a fixed pose
while it tumbles over again after getting up, one that keeps its joint targets once it
stands still, and one that hands over to a second policy when it stalls or
while it is tilted over (``scripts/policy_variants.py``; the tilt rule also labelled the shipped
``flat`` student's distillation)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from selfright.env.observations import privileged_columns
from selfright.policies.actor import ActorMLP, group_dim
from selfright.policies.base import Policy, combined_digest
from selfright.policies.history import ObsHistory
from selfright.policies.pose_blend import StanceTarget, blend_weight, pose_blend, target_for, upright_count
from selfright.policies.slots import LastActions, SlotNoise, grown, slot_index
from selfright.policies.stall import StallSwitch, TiltSwitch
from selfright.train.symmetry import group_mirrors, mirror


class MeanOf(Policy):
    """Acts with the mean of its members' actions."""

    def __init__(self, members: Sequence[Policy]):
        self.members = list(members)
        self.groups = tuple(sorted({g for p in self.members for g in p.groups}))
        self.action_mapping = self.members[0].action_mapping
        self.name = "mean of " + ", ".join(p.name for p in self.members)
        self.digest = combined_digest(self.members)

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        for p in self.members:
            p.reset(ids, seeds)

    def act(self, obs, ids, contexts):
        return torch.stack([p.act(obs, ids, contexts) for p in self.members]).mean(0)


BLIND_VALUES: dict[str, float | str] = {"velocity": 0.0, "friction": 1.0, "factors": 1.0, "scan": "height"}
"""What ``Blinded`` puts in each privileged block it hides: a number, or the name of another
block whose (single) column it copies. A trunk at rest, the nominal friction, the nominal mass
and gain factors; ``scan`` reads every scan point as the trunk's height above the ground
beneath it (the ``height`` block), which is what a flat ground would give: the terrain's shape
is hidden, the height the trunk stands at is not."""


class Blinded(Policy):
    """``inner`` (a teacher) with privileged blocks of its observation replaced by fixed
    values (``BLIND_VALUES``): how much its behaviour rests on what a student cannot sense."""

    def __init__(self, inner: Policy, blocks: Sequence[str], num_joints: int = 12):
        unknown = set(blocks) - set(BLIND_VALUES)
        if unknown:
            raise ValueError(f"cannot blind {sorted(unknown)}; choose from {sorted(BLIND_VALUES)}")
        cols = privileged_columns(num_joints)
        fills = {b: cols[v] if isinstance(v, str) else v for b, v in BLIND_VALUES.items()}
        self.inner, self.blocks = inner, [(cols[b], fills[b]) for b in blocks]
        self.groups, self.action_mapping, self.digest = inner.groups, inner.action_mapping, inner.digest
        self.name = f"{inner.name} blind to {', '.join(blocks)}"

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.inner.reset(ids, seeds)

    def act(self, obs, ids, contexts):
        x = obs["teacher"].clone()
        for cols, value in self.blocks:
            x[:, cols] = x[:, value] if isinstance(value, slice) else value
        return self.inner.act({**obs, "teacher": x}, ids, contexts)


class EstimatedVelocity(Policy):
    """``inner`` (a teacher) reading, instead of its true trunk velocity, the estimate of a
    student's velocity estimator (``--train.distillation.velocity-estimator``) from the
    student's own observation history: whether the estimate is good enough for what the
    teacher does with the velocity. Both must share an action mapping (the student's previous
    action is the teacher's)."""

    def __init__(self, inner: Policy, student: ActorMLP, num_joints: int = 12):
        if student.estimator is None:
            raise ValueError("--estimate-first needs a student with a velocity estimator")
        self.inner, self.student = inner, student
        self.columns = privileged_columns(num_joints)["velocity"]
        self.frames = ObsHistory(student.meta.obs_history, group_dim("student"))
        self.groups = tuple(sorted(set(inner.groups) | {"student", "teacher"}))
        self.action_mapping, self.digest = inner.action_mapping, inner.digest
        self.name = f"{inner.name} reading {student.meta.source or 'a student'}'s velocity estimate"

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.frames.reset(ids)
        self.inner.reset(ids, seeds)

    @torch.no_grad()
    def act(self, obs, ids, contexts):
        history = self.frames.push(ids, obs["student"].float())
        x = obs["teacher"].clone()
        x[:, self.columns] = self.student.estimate_rows(history).to(x.dtype)
        return self.inner.act({**obs, "teacher": x}, ids, contexts)


class Noisy(Policy):
    """``inner``'s mean action plus Gaussian noise of std ``std`` (per joint), seeded per episode;
    ``stream`` picks one of independent noise sequences for the same episodes."""

    def __init__(self, inner: Policy, std: torch.Tensor, stream: int = 0):
        self.inner, self.std = inner, std.float()
        self.groups, self.action_mapping = inner.groups, inner.action_mapping
        self.name = f"{inner.name} + noise"
        self.digest = inner.digest
        self._noise = SlotNoise(7) if stream == 0 else SlotNoise(7, stream)

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self._noise.reset(ids, seeds, "Noisy")
        self.inner.reset(ids, seeds)

    def act(self, obs, ids, contexts):
        a = self.inner.act(obs, ids, contexts)
        return a + self.std * self._noise.draw(ids, a.shape[1])


class Smoothed(Policy):
    """``inner``'s actions through a first-order low-pass per slot: a_t = β a_(t−1) + (1 − β) π(o_t),
    started at the episode's first action. Asks whether gentler joint targets (a slower, less
    violent escape) would keep a robot on the slope; ``scripts/policy_variants.py --smooth``."""

    def __init__(self, inner: Policy, beta: float, num_joints: int = 12):
        if not 0.0 <= beta < 1.0:
            raise ValueError(f"smoothing beta must lie in [0, 1), got {beta}")
        self.inner, self.beta = inner, float(beta)
        self.groups, self.action_mapping, self.digest = inner.groups, inner.action_mapping, inner.digest
        self.name = f"{inner.name} low-passed (beta {beta:g})"
        self._memory = LastActions(num_joints)
        """The last filtered action per slot; a fresh slot's next action passes unfiltered."""

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.inner.reset(ids, seeds)
        self._memory.reset(ids)

    def act(self, obs, ids, contexts):
        a = self.inner.act(obs, ids, contexts)
        m = self._memory
        t = m.slots(ids)
        x = a.detach().to(m.last.dtype).cpu()
        out = torch.where(m.fresh[t][:, None], x, self.beta * m.last[t] + (1.0 - self.beta) * x)
        m.last[t], m.fresh[t] = out, False
        return out.to(a.device, a.dtype)


class PoseUpright(Policy):
    """``inner``, except that once the trunk has been upright (the IMU's projected gravity
    within ``tilt_deg`` of down) for ``delay_steps`` control steps, the actions of ``columns``
    are blended towards ``target`` (action units) over ``ramp_steps`` more steps, and handed
    back at once when it tilts over. With the hips and a target of 0 this is a stance with the
    legs in their sagittal planes; with thighs and knees too, a fixed tall stance with the feet
    under the hips. Asks whether the stance the rough policies end in is what keeps their trunk
    under the goal bar (``scripts/policy_variants.py --zero-hips-upright-s``,
    ``--pose-upright-s``)."""

    def __init__(self, inner: Policy, tilt_deg: float, ramp_steps: int, columns: Sequence[int],
                 target: Sequence[float] | StanceTarget | None = None, delay_steps: int = 0,
                 label: str = "hips to 0", weight: float = 1.0):
        if ramp_steps < 1:
            raise ValueError(f"the pose ramp needs at least one step, got {ramp_steps}")
        if delay_steps < 0:
            raise ValueError(f"the pose delay cannot be negative, got {delay_steps}")
        self.inner, self.ramp, self.delay, self.cols = inner, int(ramp_steps), int(delay_steps), list(columns)
        self.weight = blend_weight(weight)
        if callable(target):  # a law of the projected gravity (a stance that leans or levels)
            self.target = target
        else:
            self.target = torch.zeros(len(self.cols)) if target is None else torch.as_tensor(target, dtype=torch.float32)
        if not callable(self.target) and self.target.shape != (len(self.cols),):
            raise ValueError(f"one target per column: {len(self.cols)} columns, target of shape {tuple(self.target.shape)}")
        self._tilted = TiltSwitch(tilt_deg)  # upright = not tilted over tilt_deg, as for the composites
        self.groups = tuple(sorted(set(inner.groups) | {"student"}))
        self.action_mapping, self.digest = inner.action_mapping, inner.digest
        share = "" if weight == 1.0 else f"{weight:g} of the way to "
        self.name = (f"{inner.name} ({share}{label} upright within {tilt_deg:g} deg, after {delay_steps} steps, "
                     f"over {ramp_steps} steps)")
        self._upright_steps = torch.zeros(0)

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.inner.reset(ids, seeds)
        t = slot_index(ids)
        self._upright_steps = grown(self._upright_steps, t)
        self._upright_steps[t] = 0.0

    def act(self, obs, ids, contexts):
        a = self.inner.act(obs, ids, contexts)
        t = slot_index(ids)
        self._upright_steps = grown(self._upright_steps, t)
        up = ~self._tilted.step(obs["student"], t)
        self._upright_steps[t] = upright_count(self._upright_steps[t], up)
        target = target_for(self.target, obs["student"][:, :3].detach().cpu().float())
        return pose_blend(a, self._upright_steps[t], self.delay, self.ramp, target, self.cols, self.weight)


class Braked(Policy):
    """``inner``, except that a robot tumbling over again after getting up holds a fixed
    ``pose`` (actions) until it lies still: once a slot's trunk has been upright within
    ``arm_deg`` (the IMU's projected gravity), a tilt past ``tilt_deg`` while the trunk turns
    faster than ``spin_rps`` starts the brake; it ends after ``calm_steps`` control steps in a
    row under ``release_rps`` or after ``max_steps``, and the slot must come upright again
    before it can brake again. Asks whether a reflex that stops the roll keeps the incline's
    re-falls on the tile (``scripts/policy_variants.py --brake-pose``). Sensor-only."""

    def __init__(self, inner: Policy, pose: Sequence[float], arm_deg: float = 45.0, tilt_deg: float = 60.0,
                 spin_rps: float = 0.0, release_rps: float = 1.0, calm_steps: int = 10, max_steps: int = 100):
        if not 0.0 < arm_deg < tilt_deg < 180.0:
            raise ValueError(f"need 0 < arm_deg < tilt_deg < 180, got {arm_deg:g} and {tilt_deg:g}")
        if calm_steps < 1 or max_steps < 1:
            raise ValueError(f"calm_steps and max_steps must be positive, got {calm_steps} and {max_steps}")
        self.inner, self.pose = inner, torch.as_tensor(pose, dtype=torch.float32)
        self._tilted_arm, self._tilted_over = TiltSwitch(arm_deg), TiltSwitch(tilt_deg)
        self.spin, self.release, self.calm_steps, self.max_steps = spin_rps, release_rps, calm_steps, max_steps
        self.groups = tuple(sorted(set(inner.groups) | {"student"}))
        self.action_mapping, self.digest = inner.action_mapping, inner.digest
        self.name = f"{inner.name} (braked past {tilt_deg:g} deg after upright)"
        self.brakes = 0
        """Brakes started since construction (a diagnostic)."""
        self._armed = torch.zeros(0, dtype=torch.bool)
        self._on = torch.zeros(0)  # steps braking so far; 0 = not braking
        self._calm = torch.zeros(0)

    def _grow(self, t: torch.Tensor) -> None:
        self._armed, self._on, self._calm = grown(self._armed, t, False), grown(self._on, t), grown(self._calm, t)

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.inner.reset(ids, seeds)
        t = slot_index(ids)
        self._grow(t)
        self._armed[t], self._on[t], self._calm[t] = False, 0.0, 0.0

    def act(self, obs, ids, contexts):
        a = self.inner.act(obs, ids, contexts)
        t = slot_index(ids)
        self._grow(t)
        x = obs["student"]
        spin = x[:, 3:6].detach().cpu().float().norm(dim=1)
        armed = self._armed[t] | ~self._tilted_arm.step(x, t)
        on = self._on[t]
        start = (on == 0) & armed & self._tilted_over.step(x, t) & (spin > self.spin)
        on = torch.where(start, torch.ones_like(on), torch.where(on > 0, on + 1, on))
        calm = torch.where((on > 0) & (spin < self.release), self._calm[t] + 1, torch.zeros_like(on))
        stop = (on > 0) & ((calm >= self.calm_steps) | (on > self.max_steps))
        on = torch.where(stop, torch.zeros_like(on), on)
        self._armed[t], self._on[t], self._calm[t] = armed & ~start, on, calm
        self.brakes += int(start.sum())
        return torch.where((on > 0)[:, None].to(a.device), self.pose.to(a.device, a.dtype).expand_as(a), a)


class Latched(Policy):
    """``inner``, except that a robot that has stood still long enough keeps the joint targets
    it stands on: once a slot's trunk has been upright within ``tilt_deg`` (the IMU's projected
    gravity) and turning slower than ``still_rps`` for ``delay_steps`` control steps in a row, the
    slot repeats the action it gave then, until the trunk tilts past ``release_deg`` (or, with
    ``hold_steps``, for at most that many steps); then ``inner`` acts again and the slot must
    stand still as long once more to latch again.
    ``inner`` is still called every step (its observation history stays current). Asks whether
    the rough policies' stand-ups that fall over again are lost to their own fidgeting once up,
    or to the ground (``scripts/policy_variants.py --latch-upright-s``). Sensor-only; needs a
    policy whose actions are targets about a fixed reference (not ``ActionConfig.reference =
    "current"``)."""

    def __init__(self, inner: Policy, delay_steps: int, tilt_deg: float = 20.0, still_rps: float = 0.5,
                 release_deg: float = 45.0, hold_steps: int | None = None):
        if delay_steps < 1:
            raise ValueError(f"the latch needs a delay of at least one step, got {delay_steps}")
        if not 0.0 < tilt_deg < release_deg < 180.0:
            raise ValueError(f"need 0 < tilt_deg < release_deg < 180, got {tilt_deg:g} and {release_deg:g}")
        if hold_steps is not None and hold_steps < 1:
            raise ValueError(f"a latch holds for at least one step, got {hold_steps}")
        self.inner, self.delay, self.still = inner, int(delay_steps), float(still_rps)
        self.hold = hold_steps
        self._up, self._held = TiltSwitch(tilt_deg), TiltSwitch(release_deg)
        self.groups = tuple(sorted(set(inner.groups) | {"student"}))
        self.action_mapping, self.digest = inner.action_mapping, inner.digest
        self.name = (f"{inner.name} (latched after {delay_steps} steps upright within {tilt_deg:g} deg under "
                     f"{still_rps:g} rad/s, released past {release_deg:g} deg"
                     + (f" or after {hold_steps} steps)" if hold_steps is not None else ")"))
        self.latches = 0
        """Latches made since construction (a diagnostic)."""
        self._still = torch.zeros(0)
        self._age = torch.zeros(0, dtype=torch.long)
        """Steps each slot has held its latched action (0 = not latched)."""
        self._action = torch.zeros(0, 0)

    def _grow(self, t: torch.Tensor, width: int) -> None:
        if self._action.shape[1] != width:
            self._action = torch.zeros(self._action.shape[0], width)
        self._still, self._age, self._action = grown(self._still, t), grown(self._age, t), grown(self._action, t)

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.inner.reset(ids, seeds)
        t = slot_index(ids)
        self._grow(t, self._action.shape[1])
        self._still[t], self._age[t] = 0.0, 0

    def act(self, obs, ids, contexts):
        a = self.inner.act(obs, ids, contexts)
        t = slot_index(ids)
        self._grow(t, a.shape[1])
        x = obs["student"]
        spin = x[:, 3:6].detach().cpu().float().norm(dim=1)
        still = upright_count(self._still[t], ~self._up.step(x, t) & (spin < self.still))
        age = self._age[t]
        on = (age > 0) & ~self._held.step(x, t)
        if self.hold is not None:
            on = on & (age < self.hold)
        start = ~on & (still >= self.delay)
        self._action[t[start]] = a.detach().cpu().float()[start]
        on = on | start
        self._age[t] = torch.where(start, torch.ones_like(age), torch.where(on, age + 1, 0))
        self._still[t] = torch.where(on, torch.zeros_like(still), still)
        self.latches += int(start.sum())
        held = self._action[t].to(a.device, a.dtype)
        return torch.where(on[:, None].to(a.device), held, a)


class SideMirrored(Policy):
    """``inner`` acting in the left-right mirror image of the world in the episodes where the
    ground falls away to one side of the trunk when it starts: at a slot's first step, the
    IMU's projected gravity has a y component (body frame) of sign ``-side`` (or the trunk
    lies level), and for the whole episode the slot then feeds ``inner`` the mirrored
    observations and returns the mirror of its actions. On an incline a one-handed policy
    (one that rolls to a preferred side, *Left-right symmetry* in docs/training.md) so rolls
    to the same side of the slope in every episode. Reads only the student group, so it is as
    sensor-only as ``inner``."""

    def __init__(self, inner: Policy, side: int, robot_name: str):
        if side not in (-1, 1):
            raise ValueError(f"side is +1 or -1, got {side}")
        self.inner, self.side, self.maps = inner, side, group_mirrors(robot_name)
        self.groups = tuple(sorted(set(inner.groups) | {"student"}))
        self.action_mapping, self.digest = inner.action_mapping, inner.digest
        self.name = f"{inner.name} (mirrored unless gravity's body y is {'+' if side > 0 else '-'} at the start)"
        self._flag = torch.zeros(0, dtype=torch.bool)
        self._decided = torch.zeros(0, dtype=torch.bool)

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.inner.reset(ids, seeds)
        t = slot_index(ids)
        self._flag, self._decided = grown(self._flag, t, False), grown(self._decided, t, False)
        self._decided[t] = False

    def act(self, obs, ids, contexts):
        t = slot_index(ids)
        self._flag, self._decided = grown(self._flag, t, False), grown(self._decided, t, False)
        new = ~self._decided[t]
        gy = obs["student"][:, 1].cpu()
        self._flag[t[new]] = (gy[new] * self.side) <= 0
        self._decided[t] = True
        flip = self._flag[t].to(obs["student"].device)[:, None]
        fed = {k: torch.where(flip, mirror(v, *self.maps[k]), v) for k, v in obs.items()}
        a = self.inner.act(fed, ids, contexts)
        return torch.where(flip.to(a.device), mirror(a, *self.maps["actions"]), a)


def trained_std(checkpoint: str) -> torch.Tensor:
    """The state-independent action std of an rsl_rl PPO checkpoint (action units)."""
    if not Path(checkpoint).is_file():
        raise ValueError(f"{checkpoint} has no state-independent action std; --noise-scale needs a PPO checkpoint file")
    sd = torch.load(checkpoint, map_location="cpu", weights_only=True).get("actor_state_dict", {})
    if "distribution.std_param" in sd:
        return sd["distribution.std_param"]
    if "distribution.log_std_param" in sd:
        return sd["distribution.log_std_param"].exp()
    raise ValueError(f"{checkpoint} has no state-independent action std; --noise-scale needs a PPO checkpoint")


class Fallback(Policy):
    """``first`` acts, and ``second`` where ``switch`` (a rule of ``selfright.policies.stall``)
    hands over: e.g. ``StallSwitch`` (for a while after the robot stalls; with a bar, an
    upright robot whose trunk is lower counts as stalled too, read from the teacher
    observation, which is then computed) or ``TiltSwitch`` (while it is tilted over).

    ``feed_both``: ``second`` sees every step of every slot, not only the handed-over ones, so
    a policy with a history of observations (a student) has an unbroken one when it takes
    over; its actions outside the hand-over are discarded."""

    def __init__(self, first: Policy, second: Policy, switch: StallSwitch | TiltSwitch, feed_both: bool = False):
        self.first, self.second, self.switch, self.feed_both = first, second, switch, feed_both
        extra = {"teacher"} if switch.needs_teacher else set()
        self.groups = tuple(sorted(set(first.groups) | set(second.groups) | extra))
        self.action_mapping = first.action_mapping
        self.name = f"{first.name}, then {second.name} when {switch.when}"
        self.digest = combined_digest([first, second])

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:
        self.first.reset(ids, seeds)
        self.second.reset(ids, seeds)
        self.switch.reset(torch.as_tensor(np.asarray(ids), dtype=torch.long))

    def act(self, obs, ids, contexts):
        x = obs["teacher"] if "teacher" in obs else obs["student"]
        rows = self.switch.step(x, torch.as_tensor(np.asarray(ids), dtype=torch.long))
        out = self.first.act(obs, ids, contexts)
        if self.feed_both:
            return torch.where(rows.unsqueeze(1).to(out.device), self.second.act(obs, ids, contexts), out)
        if rows.any():  # only the handed-over rows reach ``second`` (it may keep per-slot state)
            hand = rows.numpy()
            sub = {g: v[rows] for g, v in obs.items()}
            out[rows] = self.second.act(sub, np.asarray(ids)[hand], [c for c, h in zip(contexts, hand, strict=True) if h])
        return out
