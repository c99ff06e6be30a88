"""How far past the robot's limits do a policy's joints go? Replays a grid evaluation's episodes
(the falls of ``selfright evaluate --seed``) and reports, per joint kind (abduction, hip,
knee): how far the joints went past their stops, and how fast they turned against the motors'
published rated speed (the model's motors give full torque at any speed).

    python scripts/joint_stops.py --policy incline --grid incline --seed 4

Since 2026-12-04 the stops are stiff (``RobotConfig.joint_stop_timeconst_s`` 0.01 s); with
MuJoCo's default 0.02 s, 89 % of these episodes took an abduction joint more than 0.1 rad past
its stop (22 % now). With the default ideal servos every episode of the shipped ``incline``
turns some joint faster than the A1's rated 21 rad/s; ``--motor dcmotor`` models the motors'
torque falling to 0 at that speed (README, *What the benchmark measures*).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import tyro

from selfright.env.recovery_env import StepOutput
from selfright.evaluate.runner import ReplayArgs, replay_batches, replay_env, rollout_batch
from selfright.robots import get_robot

KINDS = ("abduction", "hip", "knee")


@dataclass(frozen=True)
class Args(ReplayArgs):
    pass


def excursions(a: ReplayArgs) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per control step of every episode: (steps, J) distance past the stops (rad) and
    (steps, J) joint speed (rad/s); per episode: (episodes, J) the largest distance past the
    stops, (episodes,) the fastest joint speed and (episodes,) success (0/1)."""
    cfg = a.bench_config()
    robot = get_robot(cfg.robot.name)
    policy = a.make_policy(cfg)
    env, cells = replay_env(a, cfg)
    past, speed, worst, top, ok = [], [], [], [], []
    for k, cell in enumerate(cells):
        for eps, seeds in replay_batches(a, cell, env.num_envs):
            most = np.zeros((len(eps), len(robot.joint_names)))
            fastest = np.zeros(len(eps))

            def watch(active: np.ndarray, out: StepOutput) -> None:
                q = out.state.q.numpy()
                beyond = np.maximum(q - robot.joint_high, 0.0) + np.maximum(robot.joint_low - q, 0.0)
                most[active] = np.maximum(most[active], beyond)
                qd = np.abs(out.state.qd.numpy())
                fastest[active] = np.maximum(fastest[active], qd.max(axis=1))
                past.append(beyond)
                speed.append(qd)

            ok.append(rollout_batch(env, policy, np.full(len(eps), k), seeds, [cell.context] * len(eps), watch))
            worst.append(most)
            top.append(fastest)
    return (np.concatenate(past), np.concatenate(speed), np.concatenate(worst), np.concatenate(top),
            np.concatenate(ok).astype(float))


def report(past: np.ndarray, speed: np.ndarray, worst: np.ndarray, rated: float | None) -> list[str]:
    """Table lines: per joint kind (every third joint, one per leg)."""
    lines = [f"{'joint':10s} {'steps >0.02 rad past':>21s} {'>0.1 rad':>9s} {'p99 (rad)':>10s} {'max (rad)':>10s}"
             + f" {'episodes >0.1 rad':>18s}"
             + (f" {'steps >' + format(rated, 'g') + ' rad/s':>18s} {'p99 (rad/s)':>12s} {'max':>6s}" if rated else "")]
    for j, kind in enumerate(KINDS):
        p, v = past[:, j::3].ravel(), speed[:, j::3].ravel()
        row = (f"{kind:10s} {100 * np.mean(p > 0.02):20.1f}% {100 * np.mean(p > 0.1):8.1f}% "
               f"{np.percentile(p, 99):10.3f} {p.max():10.3f} {100 * np.mean(worst[:, j::3].max(1) > 0.1):17.0f}%")
        if rated:
            row += f" {100 * np.mean(v > rated):17.1f}% {np.percentile(v, 99):12.1f} {v.max():6.1f}"
        lines.append(row)
    return lines


def main(a: Args) -> None:
    past, speed, worst, top, ok = excursions(a)
    rated = get_robot(a.bench_config().robot.name).rated_joint_speed
    print(f"{a.policy} on {a.grid}, seed {a.seed}: {int(ok.sum())} / {len(ok)} successes, {len(past)} control steps")
    print("\n".join(report(past, speed, worst, rated)))
    if rated:
        print(f"episodes turning a joint faster than {rated:g} rad/s: {100 * np.mean(top > rated):.0f} %, "
              f"median of their fastest {np.median(top):.1f} rad/s")


if __name__ == "__main__":
    main(tyro.cli(Args))
