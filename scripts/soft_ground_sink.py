"""How far a standing A1 sinks into softer ground: the robot set down square in its stand pose
on the flat tile, its servos holding that pose for ``--seconds``, at each ground contact time
constant (``selfright evaluate --ground-timeconst``). Prints the trunk's height above the
(undeformed) ground surface, which the goal set reads, and whether the stance is in the goal set.

    python scripts/soft_ground_sink.py --timeconsts 0.02 0.05 0.1
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch
import tyro

from selfright.config import ActionConfig, BenchmarkConfig
from selfright.env.recovery_env import RecoveryEnv
from selfright.env.world import build_world
from selfright.evaluate.runner import context_config
from selfright.robots import get_robot
from selfright.terrain.grid import grid_cells


@dataclass(frozen=True)
class Args:
    timeconsts: tuple[float, ...] = (0.02, 0.05, 0.1)
    """Ground contact time constants (s); the benchmark's is 0.02."""
    seconds: float = 2.0
    """How long the stand pose is held before the height is read (s)."""


def stand_height(timeconst_s: float, seconds: float) -> tuple[float, bool]:
    """(trunk height above the ground surface (m), in the goal set) after holding the stand pose."""
    cfg = BenchmarkConfig(action=ActionConfig(reference="stand"))
    cfg = dataclasses.replace(cfg, eval=dataclasses.replace(cfg.eval, ground_timeconst_s=timeconst_s))
    robot = get_robot(cfg.robot.name)
    env = RecoveryEnv(cfg, [build_world(grid_cells("flat", cfg.terrain)[0], cfg, context_config(cfg), 0)], 1, threads=1)
    ids = np.arange(1)
    env.reset(ids, np.zeros(1, dtype=np.int64), [np.random.default_rng(0)])
    sl, st = env.sl, env.state[0].copy()
    st[sl.pos], st[sl.quat], st[sl.qpos_joints] = [0.0, 0.0, 0.40], [1.0, 0.0, 0.0, 0.0], robot.stand_pose
    st[sl.lin_vel] = st[sl.ang_vel] = st[sl.qvel_joints] = 0.0
    env.state[0] = st
    for _ in range(max(1, round(seconds / cfg.sim.control_dt_s))):
        out = env.step(torch.zeros(1, robot.num_joints))  # action 0 = the stand pose
    height = float(env.robot_state(ids).height[0])
    env.close()
    return height, bool(out.in_goal[0])


def main(args: Args) -> None:
    for tc in args.timeconsts:
        h, goal = stand_height(tc, args.seconds)
        print(f"ground time constant {tc:g} s: trunk {h:.3f} m above the ground surface, "
              f"{'in' if goal else 'not in'} the goal set")


if __name__ == "__main__":
    main(tyro.cli(Args))
