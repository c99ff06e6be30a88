"""How much of the time does a policy keep all four feet down, acting with its mean action and
with the Gaussian noise it trained under? Table I pays 8 per second for four feet down, so a
stance that loses contact under the training noise costs the policy reward that a crouch
keeps (docs/training.md, *Why Table I crouches*). The episodes are the falls of
``selfright evaluate --grid flat --seed S``, run for the whole episode (no success stop).

    python scripts/stance_under_noise.py --seed 1 --checkpoints runs/flat_teacher/model_3445.pt runs/flat_teacher_replay/model_5127.pt

Per checkpoint and noise scale: the share of control steps with four feet down (what the feet
term pays), the same over the last 7 s, and the median trunk height over those steps.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import tyro

from selfright.config import BenchmarkConfig
from selfright.env.recovery_env import RecoveryEnv, StepOutput
from selfright.env.world import build_world
from selfright.evaluate.runner import context_config, episode_seed, rollout_batch
from selfright.policies.registry import make_policy
from selfright.policies.variants import Noisy, trained_std
from selfright.terrain.grid import grid_cells


@dataclass(frozen=True)
class Args:
    checkpoints: tuple[str, ...]
    """rsl_rl PPO checkpoints (``runs/NAME/model_K.pt``: their trained std is the noise)."""
    seed: int = 1
    episodes: int = 64
    noise_scales: tuple[float, ...] = (0.0, 1.0)
    """Multiples of each checkpoint's trained std."""
    settle_s: float = 3.0
    """Steps before this time are left out of the last-window share and the height."""


def stance(policy, env: RecoveryEnv, seeds: np.ndarray, settle_steps: int) -> tuple[float, float, float]:
    """(share of steps with four feet down, the same after ``settle_steps``, median height there)."""
    four: list[float] = []
    heights: list[float] = []

    def watch(active: np.ndarray, out: StepOutput) -> None:
        down = (out.state.feet_contact.sum(-1) == 4).numpy()
        four.append(float(down.mean()))
        if len(four) > settle_steps:
            heights.extend(out.state.height.numpy()[down].tolist())

    rollout_batch(env, policy, np.zeros(len(seeds), int), seeds, ["flat"] * len(seeds), watch)
    late = four[settle_steps:]
    return float(np.mean(four)), float(np.mean(late)) if late else float("nan"), float(np.median(heights)) if heights else float("nan")


def main(a: Args) -> None:
    cfg = BenchmarkConfig()
    cfg = dataclasses.replace(cfg, goal=dataclasses.replace(cfg.goal, hold_s=cfg.goal.episode_s + 1.0))  # never stop early
    cell = grid_cells("flat", cfg.terrain)[0]
    env = RecoveryEnv(cfg, [build_world(cell, cfg, context_config(cfg), a.seed)], a.episodes)
    seeds = np.array([episode_seed(a.seed, cell, e) for e in range(a.episodes)])
    settle = round(a.settle_s / cfg.sim.control_dt_s)
    print(f"{'checkpoint':50s} noise  four feet  after {a.settle_s:g} s  median height there")
    for ck in a.checkpoints:
        for scale in a.noise_scales:
            try:
                policy = make_policy(ck, cfg)
                if scale > 0:
                    policy = Noisy(policy, scale * trained_std(ck))
            except ValueError as e:
                raise SystemExit(f"stance_under_noise: {e}") from None
            share, late, height = stance(policy, env, seeds, settle)
            print(f"{ck:50s} {scale:5.2f}  {share:9.3f}  {late:9.3f}  {height:8.3f} m", flush=True)
    env.close()


if __name__ == "__main__":
    main(tyro.cli(Args))
