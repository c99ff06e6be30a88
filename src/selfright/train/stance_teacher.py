"""A frozen teacher that labels a fixed tall stance: distilling the ``PoseUpright`` composite
into a student.

The rough students get up and then stand low, feet spread fore and aft of the hips; blending
their actions to a fixed stance (feet under the hips, knees at their limit) once the trunk has
settled upright is worth about 10 points on ``--grid rough`` (docs/training.md, *A fixed tall
stance once upright*), and a stance reward under PPO did not find it. Here a student learns
it by distillation: the labels are a base student's own actions, blended to the stance once
the trunk has been upright (projected gravity within ``tilt_deg`` of down) for a delay, as
``selfright.policies.variants.PoseUpright`` does at evaluation. The delay is a count of steps
the student does not observe; what it learns is the expected label given its observation.

Without a stance (``--teacher STUDENT`` and no ``stance_ramp_s``) the labels are the base
student's own actions: a copy of the student, e.g. onto noisy sensors. The labelling student
always reads the *exact* student observation (group ``LABEL_GROUP``), so a student trained under
``--train.randomization.sensor-noise`` learns what the labeller does on exact sensors.

Optionally (``hold``, a ``StillHold``) the labels of a robot that has stood still over the goal
bar for a while are the student's own previous action: keep the targets, stop stepping. The
privileged teacher observation decides it (trunk height above the ground beneath it, trunk
velocity); the student learns when to hold from what its own sensors show in those states.

Optionally a second, *rescue* student labels the states where the robot has lain still, tilted
over (``StallSwitch`` without a height bar: IMU and joint speeds only), for a while: the
incline student lies still on its side in about one miss in ten, and handing those stalls to
the `flat` student at evaluation gets up from more falls (docs/training.md, *Hard joint stops*).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from selfright.env.observations import JOINT_VEL_SCALE, joint_vel_columns, prev_action_columns, privileged_columns
from selfright.policies.actor import ActorMLP
from selfright.policies.pose_blend import StanceTarget, blend_weight, pose_blend, target_for, upright_count
from selfright.policies.reference import ReferenceShift
from selfright.policies.stall import StallSwitch, TiltSwitch


class StillHold:
    """Which envs have stood still over a height for ``delay_steps`` control steps in a row, read
    from the teacher observation ``x`` (student columns first, then the privileged blocks of
    ``selfright.env.observations.privileged_columns``): upright (the caller's mask, ``StanceTeacher``'s
    tilt rule), trunk height above the ground beneath it ≥ ``height_m``, trunk speed < ``speed_mps``,
    every joint speed < ``joint_speed_rad_s``."""

    def __init__(self, num_envs: int, num_joints: int, delay_steps: int, height_m: float, speed_mps: float,
                 joint_speed_rad_s: float):
        if delay_steps < 1:
            raise ValueError(f"the hold needs a delay of at least one step, got {delay_steps}")
        cols = privileged_columns(num_joints)
        self.height_col, self.velocity = cols["height"].start, cols["velocity"]
        self.qd, self.prev = joint_vel_columns(num_joints), prev_action_columns(num_joints)
        self.delay, self.height, self.speed = int(delay_steps), float(height_m), float(speed_mps)
        self.joint_speed = float(joint_speed_rad_s) * JOINT_VEL_SCALE  # as the observation scales it
        self.count = torch.zeros(num_envs)

    def step(self, x: torch.Tensor, upright: torch.Tensor) -> torch.Tensor:
        """(n,) bool: the envs whose labels hold this step, given which are ``upright`` (n,) bool."""
        x = x.detach().cpu()
        still = (upright.cpu() & (x[:, self.height_col] >= self.height)
                 & (x[:, self.velocity].norm(dim=1) < self.speed)
                 & (x[:, self.qd].abs().amax(dim=1) < self.joint_speed))
        self.count = upright_count(self.count, still)
        return self.count >= self.delay

    def previous_action(self, x: torch.Tensor) -> torch.Tensor:
        """(n, J) the action each env took the step before (from its observation)."""
        return x[:, self.prev]

    def reset(self, done: torch.Tensor) -> None:
        self.count = self.count.masked_fill(done, 0.0)


class StanceTeacher(nn.Module):
    """``base``'s actions on the ``group`` observation, blended over ``ramp_steps`` to ``target``
    (J,) (action units; a share ``weight`` of the way) once the trunk has been upright for
    ``delay_steps`` control steps; handed straight back when it tilts over. ``target`` None: no
    stance, the labels are ``base``'s actions (a student copied, e.g. onto noisy sensors). rsl_rl's
    ``Distillation`` calls ``reset(dones)`` every step."""

    def __init__(self, base: ActorMLP, group: str, num_envs: int, tilt_deg: float, delay_steps: int,
                 ramp_steps: int, target: StanceTarget | None, weight: float = 1.0, rescue: ActorMLP | None = None,
                 rescue_group: str = "student", rescue_switch: StallSwitch | None = None,
                 rescue_offset: torch.Tensor | np.ndarray | None = None, hold: StillHold | None = None):
        """``rescue`` (reading ``rescue_group``) labels where ``rescue_switch`` hands over; its
        actions are shifted by ``rescue_offset`` (J,) (its reference pose − the base's, in action
        units; None when they share one) into the base's units. ``hold``: where it says so, the
        label is the previous action (applied after the stance blend and the rescue). ``target``
        may be a law of the trunk's projected gravity (``StanceTarget``): a stance that leans
        or levels with the trunk."""
        super().__init__()
        self.hold = hold
        if (rescue is None) != (rescue_switch is None):
            raise ValueError("a rescue student needs its hand-over rule, and the rule a rescue student")
        self.rescue, self.rescue_group, self.rescue_switch = rescue, rescue_group, rescue_switch
        self.rescue_shift = ReferenceShift(rescue_offset, num_envs)
        if target is not None and (ramp_steps < 1 or delay_steps < 0):
            raise ValueError(f"the stance needs a ramp of at least one step and a delay ≥ 0, got {ramp_steps}, {delay_steps}")
        self.base, self.group = base, group
        self.tilted = TiltSwitch(tilt_deg)
        self.delay, self.ramp, self.weight = int(delay_steps), int(ramp_steps), blend_weight(weight)
        self.law = target if callable(target) else None
        self.register_buffer("target", None if target is None or self.law is not None
                             else torch.as_tensor(target, dtype=torch.float32))
        self.count = torch.zeros(num_envs)
        """Control steps each env's trunk has been upright (CPU)."""

    @torch.no_grad()
    def forward(self, obs) -> torch.Tensor:
        x = obs["teacher"]  # the current frame's student columns come first (projected gravity at 0:3)
        up = ~self.tilted.step(x, torch.arange(x.shape[0]))
        self.count = upright_count(self.count, up)
        labels = self.base(obs[self.group])
        if self.target is not None or self.law is not None:
            target = target_for(self.law if self.law is not None else self.target, x[:, :3])
            labels = pose_blend(labels, self.count, self.delay, self.ramp, target, weight=self.weight)
        if self.rescue is not None:
            use = self.rescue_switch.step(x, torch.arange(x.shape[0])).to(labels.device)
            if use.any():
                rescued = self.rescue_shift.action(self.rescue(self.rescue_shift.obs(obs[self.rescue_group])))
                labels = torch.where(use[:, None], rescued, labels)
            self.rescue_shift.stepped()
        if self.hold is not None:
            held = self.hold.step(x, up).to(labels.device)
            if held.any():
                labels = torch.where(held[:, None], self.hold.previous_action(x).to(labels.device, labels.dtype), labels)
        return labels

    def reset(self, dones: torch.Tensor | None = None, hidden_state=None) -> None:
        if dones is not None:
            # out of place: the count may have been made under rsl_rl's inference mode
            done = dones.reshape(-1).bool().cpu()
            self.count = self.count.masked_fill(done, 0.0)
            self.rescue_shift.reset(done)
            if self.hold is not None:
                self.hold.reset(done)
            if self.rescue_switch is not None:
                self.rescue_switch.reset(done)

    def get_hidden_state(self):
        return None

    def detach_hidden_state(self, dones: torch.Tensor | None = None) -> None:
        pass
