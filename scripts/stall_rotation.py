"""Hand a stalled robot to a second policy: does a different policy get up from the falls the
first stalls in?

Twelve flat teachers miss different falls (``scripts/failure_overlap.py``), so a robot that
stalls under one might get up under another. ``first`` acts until the robot has lain still,
tilted over or upright under the goal bar (read from the teacher observation), for
``stall_s``; ``second`` then acts for ``hand_s`` and hands back
(``selfright.policies.stall.StallSwitch`` in ``selfright.policies.variants.Fallback``). With
``escape``, each of the two is itself a tilt composite (``escape`` acts while the trunk is
tilted more than ``tilt_deg``), as the composites behind the shipped students are.

    python scripts/stall_rotation.py --first runs/flat_teacher_best/model_3445.pt \\
        --second runs/flat_scratch_tall_z37/model_1271.pt --escape runs/flat_escape_std05/model_966.pt \\
        --grid flat --seed 4 --out results/rotation/s4
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import tyro

from selfright.config import BenchmarkConfig
from selfright.env.goal import goal_height_m
from selfright.evaluate.runner import evaluate_grid
from selfright.policies.base import Policy
from selfright.policies.registry import make_policy
from selfright.policies.stall import StallSwitch, TiltSwitch
from selfright.policies.variants import Fallback
from selfright.robots import get_robot


@dataclass(frozen=True)
class Args:
    first: str
    """The policy that acts until a stall (any ``--policy`` value)."""
    second: str
    """The policy a stalled robot is handed to."""
    out: Path
    """Results folder."""
    escape: str | None = None
    """A policy that acts in both halves while the trunk is tilted more than ``tilt_deg``."""
    tilt_deg: float = 45.0
    """With ``escape``: the hand-over tilt (deg)."""
    stall_s: float = 0.5
    """How long the robot must have lain still before ``second`` takes over (s)."""
    hand_s: float = 1.0
    """How long ``second`` then acts (s)."""
    below_bar: bool = True
    """Count standing or sitting still upright under a height bar as a stall; off = only lying
    still tilted over, which the IMU alone tells."""
    bar_m: float | None = None
    """The height bar (m); ``None`` = the goal set's."""
    kinematic: bool = False
    """Read the trunk height from the leg kinematics (projected gravity and joint angles: sensors
    only, ``selfright.robots.kinematics``) instead of the teacher observation's privileged height."""
    grid: str = "flat"
    episodes: int = 64
    seed: int = 0


def rotation(a: Args, cfg: BenchmarkConfig) -> Policy:
    def half(spec: str) -> Policy:
        p = make_policy(spec, cfg)
        return Fallback(p, make_policy(a.escape, cfg), TiltSwitch(a.tilt_deg)) if a.escape else p

    robot = get_robot(cfg.robot.name)
    bar = (goal_height_m(cfg.goal, robot.leg_length_m) if a.bar_m is None else a.bar_m) if a.below_bar else None
    dt = cfg.sim.control_dt_s
    switch = StallSwitch(round(a.stall_s / dt), round(a.hand_s / dt), bar, robot=robot if a.kinematic else None)
    return Fallback(half(a.first), half(a.second), switch)


def main(a: Args) -> None:
    cfg = BenchmarkConfig()
    name = f"{a.first} then (stalled {a.stall_s:g} s, for {a.hand_s:g} s) {a.second}"
    name += f", each with {a.escape} tilted over {a.tilt_deg:g} deg" if a.escape else ""
    res = evaluate_grid(rotation(a, cfg), policy_name=name, grid=a.grid, episodes=a.episodes, seed=a.seed,
                        out_dir=a.out, cfg=cfg, progress=True)
    o = res.summary["overall"]
    print(f"{name} on {a.grid} [seed {a.seed}]: {o['success_rate']:.1%} of {o['n']}")


if __name__ == "__main__":
    main(tyro.cli(Args))
