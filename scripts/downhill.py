"""How far down the slope do a policy's robots go, and does it matter where and how the fall
came to rest? Replays a grid evaluation's episodes (the falls of ``selfright evaluate --seed``)
and reports success by the trunk's position along the slope and by its tilt from vertical when
the policy takes over (after the 2 s settle), and how far each episode travelled downhill
before it ended.

    python scripts/downhill.py --policy incline --grid incline --seed 4 5 6 7

Robots are dropped over the central 2 m of the 8 m tile, slide during the settle, and fail
once the trunk comes within 0.5 m of the edge (``EDGE_MARGIN_M``), 3.5 m from the centre.
On the 20° incline the slope rises along +x, so a fall that came to rest at x = −1.5 m has
2 m of slope left below it. Lying flat on the belly on the 20° slope reads a tilt of 20°,
on the back 160°: on seeds 4–11 the shipped ``incline`` gets up from 92 % of the falls that
came to rest on their back but from 75 % of those within 32° of upright (docs/training.md).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import tyro

from selfright.env.recovery_env import StepOutput
from selfright.evaluate.runner import ReplayArgs, replay_batches, replay_env, rollout_batch

BINS_M = (-3.5, -1.5, -1.0, -0.5, 0.0, 0.5, 3.5)
TILT_BINS_DEG = (0.0, 32.0, 60.0, 90.0, 120.0, 180.01)


@dataclass(frozen=True)
class Args(ReplayArgs):
    grid: str = "incline"
    seeds: tuple[int, ...] = ()
    """Run seeds to pool (``--seed`` alone if empty)."""


def travel(a: ReplayArgs) -> np.ndarray:
    """(n, 4): x when control starts, x at the end (m, +x uphill), success (0/1), and the trunk's
    tilt from vertical when control starts (deg) per episode; "when control starts" is the state
    after the first control step (0.02 s in)."""
    cfg = a.bench_config()
    policy = a.make_policy(cfg)
    env, cells = replay_env(a, cfg)
    rows = []
    for k, cell in enumerate(cells):
        for eps, seeds in replay_batches(a, cell, env.num_envs):
            first: dict[int, tuple[float, float]] = {}
            last: dict[int, float] = {}

            def watch(active: np.ndarray, out: StepOutput) -> None:
                x = out.state.pos[:, 0].numpy()
                tilt = np.degrees(np.arccos(np.clip(out.state.rot[:, 2, 2].numpy(), -1.0, 1.0)))
                for j, i in enumerate(active):
                    first.setdefault(int(i), (float(x[j]), float(tilt[j])))
                    last[int(i)] = float(x[j])

            ok = rollout_batch(env, policy, np.full(len(eps), k), seeds, [cell.context] * len(eps), watch)
            rows += [(first[i][0], last[i], float(ok[i]), first[i][1]) for i in sorted(first)]
    env.close()
    return np.array(rows).reshape(-1, 4)


def main(a: Args) -> None:
    seeds = a.seeds or (a.seed,)
    r = np.concatenate([travel(dataclasses.replace(a, seed=s)) for s in seeds])
    x0, x1, ok, tilt = r[:, 0], r[:, 1], r[:, 2].astype(bool), r[:, 3]
    print(f"{a.label} on --grid {a.grid}, seeds {', '.join(map(str, seeds))}: {ok.sum()} / {len(ok)} = {100 * ok.mean():.1f} %")
    print(" x when control starts (m)  episodes  success")
    for lo, hi in zip(BINS_M[:-1], BINS_M[1:]):
        m = (x0 >= lo) & (x0 < hi)
        if m.any():
            print(f"  [{lo:+.1f}, {hi:+.1f})            {m.sum():8d}  {100 * ok[m].mean():6.1f} %")
    print(" tilt when control starts (deg)  episodes  success")
    for lo, hi in zip(TILT_BINS_DEG[:-1], TILT_BINS_DEG[1:]):
        m = (tilt >= lo) & (tilt < hi)
        if m.any():
            print(f"  [{lo:3.0f}, {min(hi, 180):3.0f})                  {m.sum():8d}  {100 * ok[m].mean():6.1f} %")
    for name, m in (("successes", ok), ("failures", ~ok)):
        if m.any():
            q = np.percentile((x1 - x0)[m], [10, 50, 90])
            print(f"downhill travel of the {name} (m, + = uphill): 10 / 50 / 90 % {q[0]:+.2f} / {q[1]:+.2f} / {q[2]:+.2f}")


if __name__ == "__main__":
    main(tyro.cli(Args))
