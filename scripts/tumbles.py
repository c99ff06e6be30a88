"""How do a policy's robots fall over again after getting up? Replays a grid evaluation's
episodes (the falls of ``selfright evaluate --seed``) and lists every *re-fall*: the trunk
within 45° of upright (world z) for one or more control steps, then tilted past 45° again.
For each one it prints how long the robot had been upright, how many feet were on the ground
on average meanwhile, its trunk height, and which way the trunk tipped on the incline
(the slope rises along +x: 0° = uphill, 180° = downhill, ±90° = across the slope).

    python scripts/tumbles.py --policy incline --grid incline --episodes 64 --seed 0

On the incline most failures are episodes that get up and then tumble downhill off the tile
(``scripts/failure_modes.py`` marks them "stood up, then fell over"); this shows whether the
robot had stood (feet down, seconds upright) or was passing upright mid-tumble.

It also prints how fast each robot was moving downhill as it came upright (the trunk's −x
speed, averaged over the spell's first ``ARRIVAL_S``), for the re-falls and for the upright
stays that end the successful episodes. For the shipped `incline` (seeds 0 and 4–7) the
re-falls of the failed episodes arrive faster downhill than the robots that stay up (a median
0.82 against about 0.48 m/s) and higher
(docs/training.md, *A stance that stands on the slope, distilling it, and slower arrivals*).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import tyro

from selfright.env.recovery_env import StepOutput
from selfright.evaluate.runner import ReplayArgs, replay_batches, replay_env, rollout_batch

COS_45 = float(np.cos(np.radians(45.0)))
ARRIVAL_S = 0.2
"""How long after coming upright the arrival speed is averaged over (s)."""


@dataclass
class Refall:
    episode_ok: bool
    upright_s: float
    mean_feet: float
    max_height_m: float
    tip_deg: float
    """Direction the trunk's up axis tipped towards, in the world x-y plane (0° = +x, uphill)."""
    downhill_mps: float = float("nan")
    """Downhill speed (−v_x) over the spell's first ``ARRIVAL_S`` (NaN without the series)."""


def arrival_speed(downhill: np.ndarray | None, start: int, stop: int, dt: float) -> float:
    """Mean of ``downhill`` over the first ``ARRIVAL_S`` of the spell [start, stop)."""
    if downhill is None:
        return float("nan")
    return float(downhill[start:min(stop, start + max(1, round(ARRIVAL_S / dt)))].mean())


def refalls(up_z: np.ndarray, tip: np.ndarray, feet: np.ndarray, height: np.ndarray, ok: bool, dt: float,
            downhill: np.ndarray | None = None) -> list[Refall]:
    """Re-falls of one episode from its per-step series (steps in order); ``downhill`` the
    trunk's downhill speed per step (m/s)."""
    out, start = [], None
    for s, z in enumerate(up_z):
        if z > COS_45 and start is None:
            start = s
        elif z <= COS_45 and start is not None:
            w = slice(start, s)
            out.append(Refall(ok, (s - start) * dt, float(feet[w].mean()), float(height[w].max()), float(tip[s]),
                              arrival_speed(downhill, start, s, dt)))
            start = None
    return out


def final_stay(up_z: np.ndarray, height: np.ndarray, downhill: np.ndarray, dt: float) -> tuple[float, float] | None:
    """(downhill speed on arrival, max height) of the upright spell an episode ends in; None
    when it ends tilted over 45°."""
    if up_z[-1] <= COS_45:
        return None
    tilted = np.flatnonzero(up_z <= COS_45)
    start = int(tilted[-1]) + 1 if len(tilted) else 0
    return arrival_speed(downhill, start, len(up_z), dt), float(height[start:].max())


def main(a: ReplayArgs) -> None:
    cfg = a.bench_config()
    policy = a.make_policy(cfg)
    env, cells = replay_env(a, cfg)
    events: list[Refall] = []
    stays: list[tuple[float, float]] = []  # the successful episodes' final upright spells
    for k, cell in enumerate(cells):
        for eps, seeds in replay_batches(a, cell, env.num_envs):
            series: list[list[tuple[float, ...]]] = [[] for _ in eps]

            def watch(active: np.ndarray, out: StepOutput) -> None:
                rot = out.state.rot.numpy()
                tip = np.degrees(np.arctan2(rot[:, 1, 2], rot[:, 0, 2]))
                feet = out.state.feet_contact.sum(dim=-1).numpy()
                height = out.state.height.numpy()
                downhill = -out.state.lin_vel[:, 0].numpy()  # the incline rises along +x
                for j, i in enumerate(active):
                    series[i].append((rot[j, 2, 2], tip[j], feet[j], height[j], downhill[j]))

            success = rollout_batch(env, policy, np.full(len(eps), k), seeds, [cell.context] * len(eps), watch)
            for i, rows in enumerate(series):
                r = np.array(rows)
                events += refalls(r[:, 0], r[:, 1], r[:, 2], r[:, 3], bool(success[i]), env.control_dt, r[:, 4])
                stay = final_stay(r[:, 0], r[:, 3], r[:, 4], env.control_dt) if success[i] else None
                stays += [stay] if stay is not None else []
    env.close()
    print(f"{len(events)} re-falls in {a.episodes * len(cells)} episodes ({a.label} on --grid {a.grid}, seed {a.seed})")
    if not events:
        return
    print(" episode ok  upright (s)  mean feet down  max height (m)  tipped towards (deg, 0 = +x uphill)"
          "  downhill on arrival (m/s)")
    for e in events:
        print(f"  {e.episode_ok!s:5}  {e.upright_s:11.2f}  {e.mean_feet:14.2f}  {e.max_height_m:14.3f}  {e.tip_deg:8.0f}"
              f"  {e.downhill_mps:26.2f}")
    d = np.array([e.upright_s for e in events])
    feet = np.array([e.mean_feet for e in events])
    tip = np.abs(np.array([e.tip_deg for e in events]))
    print(f"upright before the re-fall: median {np.median(d):.2f} s; under 0.5 s: {(d < 0.5).sum()}; "
          f"mean feet down under 2: {(feet < 2).sum()}")
    print(f"tipped within 45° of downhill: {(tip > 135).sum()}, of uphill: {(tip < 45).sum()}, "
          f"across the slope: {((tip >= 45) & (tip <= 135)).sum()}")
    long = [e for e in events if e.upright_s >= ARRIVAL_S]
    for label, rows in (("re-falls in failed episodes", [(e.downhill_mps, e.max_height_m) for e in long if not e.episode_ok]),
                        ("re-falls in successful episodes", [(e.downhill_mps, e.max_height_m) for e in long if e.episode_ok]),
                        ("successful episodes' final stays", stays)):
        if rows:
            v, h = np.array(rows).T
            print(f"{label} (upright ≥ {ARRIVAL_S:g} s: {len(rows)}): downhill on arrival median {np.median(v):.2f} m/s "
                  f"(quartiles {np.percentile(v, 25):.2f}–{np.percentile(v, 75):.2f}), max height median {np.median(h):.3f} m")


if __name__ == "__main__":
    main(tyro.cli(ReplayArgs))
