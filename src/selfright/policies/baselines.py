"""Baseline controllers: hold still, random, and a scripted open-loop righting routine."""

from __future__ import annotations

import math

import numpy as np
import torch

from selfright.config import ActionConfig
from selfright.policies.base import Policy
from selfright.robots import RobotSpec

# Student observation layout (see env.observations.student_obs).
_GRAV = slice(0, 3)
_Q0 = 6


def joint_angles(obs: torch.Tensor, robot: RobotSpec) -> torch.Tensor:
    """(k, J) joint angles (rad) from a ``student`` (or ``teacher``) observation (k, D)."""
    nj = robot.num_joints
    return obs[:, _Q0 : _Q0 + nj] + torch.as_tensor(robot.nominal_pose, dtype=obs.dtype)


class TargetPolicy(Policy):
    """Base for controllers that think in joint targets rather than actions (the scripted
    baselines)."""

    groups = ("student",)

    def __init__(self, robot: RobotSpec, action: ActionConfig):
        self.robot = robot
        self.action = action
        pose = robot.reference_pose(action.reference)
        self._ref = None if pose is None else torch.as_tensor(pose, dtype=torch.float32)
        self._low = torch.as_tensor(robot.joint_low, dtype=torch.float32)
        self._high = torch.as_tensor(robot.joint_high, dtype=torch.float32)

    def to_target(self, action: torch.Tensor, q: torch.Tensor) -> torch.Tensor:
        """PD targets (k, J) the env makes of ``action`` (k, J) given current angles ``q`` (k, J):
        the action clipped to ±``clip``, reference + scale · action, within the joint range
        (``RecoveryEnv._targets``)."""
        ref = q if self._ref is None else self._ref
        target = ref + self.action.scale_rad * action.clamp(-self.action.clip, self.action.clip)
        return torch.minimum(torch.maximum(target, self._low), self._high)

    def to_action(self, target: torch.Tensor, q: torch.Tensor) -> torch.Tensor:
        """Action whose PD target is ``target`` (k, J) given current angles ``q`` (k, J)."""
        ref = q if self._ref is None else self._ref
        return (target - ref) / self.action.scale_rad


class ZeroPolicy(TargetPolicy):
    """Holds the joint angles the robot had when the policy started (the settled pose)."""

    name = "zero"

    def __init__(self, robot: RobotSpec, action: ActionConfig):
        super().__init__(robot, action)
        self._hold: dict[int, torch.Tensor] = {}

    def reset(self, ids, seeds=None):
        for i in np.asarray(ids).tolist():
            self._hold.pop(i, None)

    @torch.no_grad()
    def act(self, obs, ids, cells):
        q = joint_angles(obs["student"], self.robot)
        hold = []
        for k, i in enumerate(np.asarray(ids).tolist()):
            if i not in self._hold:
                self._hold[i] = q[k].clone()
            hold.append(self._hold[i])
        return self.to_action(torch.stack(hold), q)


class RandomPolicy(Policy):
    """Uniform random actions in [-1, 1], from a generator seeded per episode."""

    name = "random"
    groups = ("student",)

    def __init__(self, num_joints: int):
        self.nj = num_joints
        self._rng: dict[int, np.random.Generator] = {}

    def reset(self, ids, seeds=None):
        seeds = np.zeros(len(ids), dtype=np.int64) if seeds is None else np.asarray(seeds)
        for i, s in zip(np.asarray(ids).tolist(), seeds.tolist()):
            self._rng[i] = np.random.default_rng([int(s), 0x5EED])

    @torch.no_grad()
    def act(self, obs, ids, cells):
        rows = [self._rng.setdefault(i, np.random.default_rng(i)).uniform(-1, 1, self.nj) for i in np.asarray(ids).tolist()]
        return torch.as_tensor(np.stack(rows), dtype=torch.float32)


# Phases of the scripted routine.
TUCK, ROLL, STAND, HOLD = 0, 1, 2, 3


class OpenLoopPolicy(TargetPolicy):
    """A scripted righting routine of the kind commercial quadrupeds ship.

    Fixed joint-space key poses, switched on timers and on the IMU's tilt only (no terrain
    awareness, no feedback beyond "am I upright yet"):

    1. TUCK (0.04 s): fold every leg against the trunk.
    2. ROLL (0.3 s): the legs on one side extend through the trunk's top side and out,
       levering the trunk towards the side that is already lower; the other legs stay
       folded. Then tuck and push from the other side: the alternation rocks the trunk with
       growing amplitude until it rolls over (a static push alone tilts the A1 only ~25°,
       its hip abduction range being ±46°).
    3. STAND (1.0 s), entered once the IMU says the trunk is upright (up axis within 60° of
       vertical): all legs to the crouch pose, then to the standing pose.
    4. HOLD: keep the standing pose; the routine stops, as commercial ones do. If the IMU
       reports the trunk tipped over again (STAND or HOLD), it starts over at TUCK.
    """

    name = "open-loop"

    def __init__(
        self,
        robot: RobotSpec,
        action: ActionConfig,
        control_dt: float,
        *,
        tuck_s: float = 0.04,
        roll_s: float = 0.3,
        stand_s: float = 1.0,
        upright_deg: float = 60.0,
    ):
        super().__init__(robot, action)
        self.dt = control_dt
        self.tuck_steps = int(round(tuck_s / control_dt))
        self.roll_steps = int(round(roll_s / control_dt))
        self.stand_steps = int(round(stand_s / control_dt))
        self.upright_cos = math.cos(math.radians(upright_deg))
        self._mem: dict[int, list[int]] = {}  # slot -> [phase, steps in phase, roll side]
        side = torch.tensor([-1.0, 1.0, -1.0, 1.0])  # +1 = left legs (FR, FL, RR, RL)
        self.leg_side = side
        self.tuck = torch.tensor([0.0, 1.5, -2.6] * 4)
        self.crouch = torch.as_tensor(robot.nominal_pose, dtype=torch.float32)
        self.stand = torch.as_tensor(robot.stand_pose, dtype=torch.float32)

    def reset(self, ids, seeds=None):
        for i in np.asarray(ids).tolist():
            self._mem.pop(i, None)

    def roll_pose(self, roll_side: float) -> torch.Tensor:
        """Legs on the side opposite to ``roll_side`` push; the others stay tucked."""
        pose = self.tuck.clone().reshape(4, 3)
        pushers = self.leg_side == -roll_side
        # Thigh swung through the trunk's top (θ ≈ π), tilted outwards by abduction, knee open.
        pose[pushers, 0] = -0.6 * self.leg_side[pushers]
        pose[pushers, 1] = 3.3
        pose[pushers, 2] = -0.95
        return pose.reshape(-1)

    @torch.no_grad()
    def act(self, obs, ids, cells):
        student = obs["student"]
        q = joint_angles(student, self.robot)
        grav = student[:, _GRAV]
        upright = -grav[:, 2] >= self.upright_cos
        targets = []
        for k, i in enumerate(np.asarray(ids).tolist()):
            mem = self._mem.setdefault(i, [TUCK, 0, 1.0 if grav[k, 1] >= 0 else -1.0])
            phase, t, side = mem
            if phase in (TUCK, ROLL) and upright[k]:
                phase, t = STAND, 0
            elif phase in (STAND, HOLD) and not upright[k]:
                phase, t, side = TUCK, 0, (1.0 if grav[k, 1] >= 0 else -1.0)
            elif phase == TUCK and t >= self.tuck_steps:
                phase, t = ROLL, 0
            elif phase == ROLL and t >= self.roll_steps:
                phase, t, side = TUCK, 0, -side
            elif phase == STAND and t >= self.stand_steps:
                phase, t = HOLD, 0
            if phase == TUCK:
                target = self.tuck
            elif phase == ROLL:
                target = self.roll_pose(side)
            elif phase == STAND:
                target = self.crouch if t < self.stand_steps // 2 else self.stand
            else:
                target = self.stand
            mem[:] = [phase, t + 1, side]
            targets.append(target)
        return self.to_action(torch.stack(targets), q)
