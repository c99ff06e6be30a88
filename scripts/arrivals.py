"""How do a policy's robots arrive upright, and does the arrival decide the episode? Replays a
grid evaluation's episodes (the falls of ``selfright evaluate --seed``) and, at the first
control step where the trunk comes within 45° of upright, records the trunk's angular speed,
its linear speed, the feet on the ground and the trunk's height; then prints the episodes'
success rate by bins of the arrival's angular speed and feet down.

    python scripts/arrivals.py --policy incline --grid incline --episodes 64 --seeds 4 5 6 7

``scripts/stand_test.py`` starts robots already standing; this shows what the get-ups
actually hand over to the stance phase.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import tyro

from selfright.env.recovery_env import StepOutput
from selfright.evaluate.runner import ReplayArgs, replay_batches, replay_env, rollout_batch

COS_45 = float(np.cos(np.radians(45.0)))
SPEED_BINS = (0.0, 1.0, 2.0, 3.0, 5.0, np.inf)
"""Arrival angular speed bins (rad/s)."""


@dataclass(frozen=True)
class Args(ReplayArgs):
    seeds: tuple[int, ...] = ()
    """Run seeds to pool (each the episodes of ``selfright evaluate --seed``); empty = ``seed``."""


def arrivals(a: ReplayArgs) -> list[tuple[float, float, float, float, bool]]:
    """(ω, v, feet down, height, success) at the first step within 45° of upright, per episode
    that gets there."""
    cfg = a.bench_config()
    policy = a.make_policy(cfg)
    env, cells = replay_env(a, cfg)
    rows: list[tuple[float, float, float, float, bool]] = []
    for k, cell in enumerate(cells):
        for eps, seeds in replay_batches(a, cell, env.num_envs):
            first: dict[int, tuple[float, float, float, float]] = {}

            def watch(active: np.ndarray, out: StepOutput) -> None:
                up = out.state.rot[:, 2, 2].numpy()
                w = np.linalg.norm(out.state.ang_vel.numpy(), axis=1)
                v = np.linalg.norm(out.state.lin_vel.numpy(), axis=1)
                feet = out.state.feet_contact.sum(dim=-1).numpy()
                h = (out.state.pos[:, 2] - out.state.ground_z).numpy()
                for j, i in enumerate(active):
                    if i not in first and up[j] > COS_45:
                        first[int(i)] = (float(w[j]), float(v[j]), float(feet[j]), float(h[j]))

            success = rollout_batch(env, policy, np.full(len(eps), k), seeds, [cell.context] * len(eps), watch)
            for i in range(len(eps)):
                if i in first:
                    rows.append((*first[i], bool(success[i])))
    env.close()
    return rows


def main(a: Args) -> None:
    seeds = a.seeds or (a.seed,)
    rows = [row for s in seeds for row in arrivals(replace(a, seed=s))]
    r = np.array(rows, dtype=float)
    print(f"{len(r)} episodes came within 45° of upright ({a.label} on --grid {a.grid}, "
          f"{a.episodes} episodes per cell, seeds {', '.join(map(str, seeds))})")
    if not len(r):
        return
    print(f"  success among them: {r[:, 4].mean():.1%}; arrival |ω| median {np.median(r[:, 0]):.2f} rad/s, "
          f"|v| median {np.median(r[:, 1]):.2f} m/s, feet down median {np.median(r[:, 2]):.0f}")
    print("  arrival |ω| (rad/s)   episodes   success")
    for lo, hi in zip(SPEED_BINS[:-1], SPEED_BINS[1:]):
        m = (r[:, 0] >= lo) & (r[:, 0] < hi)
        if m.any():
            print(f"  {lo:4.1f} – {hi:<4.1f}        {m.sum():8d}   {r[m, 4].mean():6.1%}")
    print("  feet down at arrival   episodes   success")
    for f in range(5):
        m = r[:, 2] == f
        if m.any():
            print(f"  {f:d}                      {m.sum():8d}   {r[m, 4].mean():6.1%}")


if __name__ == "__main__":
    main(tyro.cli(Args))
