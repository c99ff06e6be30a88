"""Can a policy stay up once it is up? Each episode starts with the robot standing on the
training context's ground (``--train.episode.stand-start``'s draw: square to the ground at a
random heading, tilted up to ``--tilt-deg``, joints near the policy's action reference, a
random trunk velocity), then the policy acts for ``--seconds``. The script prints, per
policy, the share of episodes that complete the goal set's hold (the benchmark's success)
and the share still upright (goal-set roll and pitch) at the end. Every policy meets the
same starts. Not the seed's protocol: a diagnostic of balance, apart from the get-up.

    python scripts/stand_test.py --policies incline runs/incline_sppo_stand30/model_3251.pt
    python scripts/stand_test.py --policies incline --lin-vel-mps 0 --ang-vel-rps 0   # standing still
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch
import tyro

from selfright.config import BenchmarkConfig
from selfright.env.goal import upright
from selfright.policies.registry import make_policy
from selfright.train.config import EpisodeConfig, RandomizationConfig, TrainConfig
from selfright.train.contexts import make_training_worlds
from selfright.train.vecenv import RecoveryVecEnv


@dataclass(frozen=True)
class Args:
    policies: tuple[str, ...] = ("incline",)
    context: str = "incline"
    episodes: int = 256
    seconds: float = 4.0
    seed: int = 0
    action_reference: str = "tall"
    """The env's action mapping, whose pose the starts stand in (a policy trained for another
    is converted, as ``selfright evaluate`` does)."""
    tilt_deg: float = 15.0
    joint_noise_rad: float = 0.15
    lin_vel_mps: float = 0.5
    ang_vel_rps: float = 1.0


def run(policy_name: str, a: Args) -> tuple[float, float]:
    """(share that completed the goal hold, share upright at the end) of ``a.episodes`` standing starts."""
    base = BenchmarkConfig()
    cfg = dataclasses.replace(base, action=dataclasses.replace(base.action, reference=a.action_reference))
    policy = make_policy(policy_name, cfg)
    ep = EpisodeConfig(stand_start=1.0, stand_start_tilt_deg=a.tilt_deg, stand_start_joint_noise_rad=a.joint_noise_rad,
                       stand_start_lin_vel_mps=a.lin_vel_mps, stand_start_ang_vel_rps=a.ang_vel_rps)
    train = dataclasses.replace(TrainConfig(), episode=ep, randomization=RandomizationConfig(enabled=False))
    worlds = make_training_worlds(a.context, cfg, a.seed, ep)
    vec = RecoveryVecEnv(cfg, train, worlds, a.episodes, seed=a.seed)
    env, ids = vec.env, np.arange(a.episodes)
    policy.reset(ids, np.arange(a.episodes) + 1_000_000 * a.seed)
    contexts = [a.context] * a.episodes
    done = np.zeros(a.episodes, dtype=bool)
    succeeded = np.zeros(a.episodes, dtype=bool)
    with torch.inference_mode():
        for _ in range(int(round(a.seconds / env.control_dt))):
            live = ids[~done]
            if not len(live):
                break
            out = env.step(policy.act(env.observe(live, policy.groups), live, [contexts[i] for i in live]), live)
            succeeded[live] |= out.succeeded.numpy()
            done[live] |= out.failed.numpy()
    rs = env.robot_state(ids)
    up = upright(rs.roll, rs.pitch, cfg.goal).numpy() & ~done
    vec.close()
    return float(succeeded.mean()), float(up.mean())


def main(a: Args) -> None:
    print(f"{a.episodes} standing starts on {a.context}, {a.seconds} s each (tilt ≤ {a.tilt_deg}°, "
          f"|v| ≤ {a.lin_vel_mps} m/s, |ω| ≤ {a.ang_vel_rps} rad/s per axis, seed {a.seed})")
    for name in a.policies:
        ok, up = run(name, a)
        print(f"  {name}: goal hold completed {ok:6.1%}, upright at the end {up:6.1%}")


if __name__ == "__main__":
    main(tyro.cli(Args))
