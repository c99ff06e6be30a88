"""Why does a policy fail? Replays a grid evaluation's episodes (same seeds, same falls as
``selfright evaluate``) and sorts each failed episode by the state it ended in:

    left tile / diverged      the episode was cut short
    not upright               |roll| or |pitch| > 30° at the end
    upright, feet off         upright but fewer than four feet on the ground
    upright, 4 feet, low      upright on four feet, trunk below the goal bar
    in goal, no 1 s hold      in the goal set at the end or earlier, but never for the full hold

Two markers count failures of any class: "(was in goal earlier)", and "(stood up, then fell
over)": the trunk was within 45° of upright at some step and tilted past 90° at a later one.
On the incline most episodes that leave the tile carry the second: they tumble downhill after
getting up, not while lying on the back.

and prints, for the "feet off" class, how high the lifted feet hang over the ground beneath them
(foot centres: a foot resting on the ground reads about its 0.02 m radius), for the "low" class, the trunk height above the ground beneath it and above the
mean ground under the feet (they differ on rough tiles; the goal set reads the first) and how
long the robot had stood upright on four feet when the episode ended, the same height for the
successes (the margin they clear the bar by), and,
over every episode that ends upright on four feet (successes included), the median stance:
trunk height over the feet and each leg's hip, thigh and knee angles.

    python scripts/failure_modes.py --policy rough --grid rough --episodes 64
    python scripts/failure_modes.py --policy incline --grid incline --stance-weight 0.3   # blended to the stance

``--tile-size-m 24`` replays the same falls on a larger tile (not the benchmark's): do the
episodes that leave the 8 m tile get up further down the slope?
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import torch
import tyro

from selfright.env.goal import goal_height_m, upright
from selfright.env.recovery_env import StepOutput
from selfright.evaluate.runner import ReplayArgs, replay_batches, replay_env, rollout_batch

COS_45 = float(np.cos(np.radians(45.0)))


def main(a: ReplayArgs) -> None:
    cfg = a.bench_config()
    policy = a.make_policy(cfg)
    env, cells = replay_env(a, cfg)
    bar = goal_height_m(cfg.goal, env.robot.leg_length_m)
    for k, cell in enumerate(cells):
        classes: Counter[str] = Counter()
        low_h: list[tuple[float, float, float]] = []
        success_h: list[float] = []
        stances: list[np.ndarray] = []  # (height over feet, J joint angles) of every end on four feet, upright
        lifted: list[float] = []  # the lifted feet's gaps over the ground beneath them, "feet off" ends
        for eps, seeds in replay_batches(a, cell, env.num_envs):
            ids = np.arange(len(eps))
            ever_goal = np.zeros(len(eps), bool)
            failed = np.zeros(len(eps), bool)
            was_up = np.zeros(len(eps), bool)
            fell_over = np.zeros(len(eps), bool)
            standing = np.zeros(len(eps))  # control steps upright on four feet, up to now

            def watch(active: np.ndarray, out: StepOutput) -> None:
                st = out.state
                stands = upright(st.roll, st.pitch, cfg.goal).numpy() & (st.feet_contact.sum(dim=-1).numpy() == 4)
                standing[active] = np.where(stands, standing[active] + 1, 0)
                ever_goal[active] |= out.in_goal.numpy()
                up_z = out.state.up_z.numpy()
                fell_over[active] |= was_up[active] & (up_z < 0.0)
                was_up[active] |= up_z > COS_45
                failed[active[out.failed.numpy()]] = True

            success = rollout_batch(env, policy, np.full(len(eps), k), seeds, [cell.context] * len(eps), watch)
            failed |= env.diverged[torch.from_numpy(ids)].numpy()
            # Slots keep their final state (and sensors) until the next reset: classify it.
            st = env.robot_state(ids)
            is_up = upright(st.roll, st.pitch, cfg.goal).numpy()
            contact = st.feet_contact.numpy().astype(bool)
            feet_down = contact.sum(axis=1)
            height = st.height.numpy()
            over_feet = env.height_over_feet(ids)
            feet = env.feet_xyz(ids)  # (k, F, 3) foot geom centres
            gap = feet[:, :, 2] - env.ground_under_feet(ids, feet)
            q = st.q.numpy()
            for i in ids:
                if is_up[i] and feet_down[i] == 4:
                    stances.append(np.concatenate([[over_feet[i]], q[i]]))
                if success[i]:
                    classes["success"] += 1
                    success_h.append(float(height[i]))
                    continue
                up, feet, h = bool(is_up[i]), int(feet_down[i]), float(height[i])
                h_feet = float(over_feet[i])
                if failed[i]:
                    classes["left tile / diverged"] += 1
                elif not up:
                    classes["not upright"] += 1
                elif feet < 4:
                    classes["upright, feet off"] += 1
                    lifted.extend(gap[i][~contact[i]].tolist())
                elif h < bar:
                    classes["upright, 4 feet, low"] += 1
                    low_h.append((h, h_feet, standing[i] * cfg.sim.control_dt_s))
                else:
                    classes["in goal, no 1 s hold"] += 1
                if ever_goal[i] and not (up and feet == 4 and h >= bar):
                    classes["(was in goal earlier)"] += 1
                if fell_over[i]:
                    classes["(stood up, then fell over)"] += 1
        print(f"cell slope {cell.slope_pct:.0f} %, roughness level {cell.roughness_level} ({a.episodes} episodes):")
        for name, n in classes.most_common():
            print(f"  {name:26s} {n:4d}")
        if low_h:
            h = np.array(low_h)
            print(f"  low: height above ground beneath trunk median {np.median(h[:, 0]):.3f} m; "
                  f"above mean foot ground median {np.median(h[:, 1]):.3f} m (bar {bar:.2f} m); "
                  f"had stood upright on four feet for a median {np.median(h[:, 2]):.1f} s")
        if lifted:
            g = np.array(lifted)
            print(f"  feet off: {len(g)} lifted feet, their centres {np.median(g):.3f} m over the ground beneath "
                  f"them (median; 10th–90th percentile {np.percentile(g, 10):.3f}–{np.percentile(g, 90):.3f} m)")
        if success_h:
            p10, p50, p90 = np.percentile(success_h, [10, 50, 90])
            print(f"  successes end {p50:.3f} m above the ground beneath the trunk (10th–90th percentile "
                  f"{p10:.3f}–{p90:.3f} m)")
        if stances:
            m = np.median(np.array(stances), axis=0)
            legs = "  ".join(f"{n.split('_')[0]} " + " ".join(f"{v:+.2f}" for v in leg)
                             for n, leg in zip(env.robot.joint_names[::3], m[1:].reshape(-1, 3)))
            print(f"  stance (the {len(stances)} ending upright on four feet): {m[0]:.3f} m over the feet; "
                  f"hip thigh knee (rad) {legs}")
    env.close()


if __name__ == "__main__":
    main(tyro.cli(ReplayArgs))
