"""How well a student's trunk-velocity estimator (``--train.distillation.velocity-estimator``)
tracks the true body-frame velocity on its own rollouts in the training env (falls, settling,
domain randomisation as in training; the student acts with its mean action): RMS error and
R² per axis, and the spread of the true velocity.

    python scripts/estimator_accuracy.py --checkpoint runs/incline_student_vel/model_299.pt --context incline
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import torch
import tyro
from tqdm import tqdm

from selfright.config import ActionConfig, BenchmarkConfig
from selfright.env.observations import privileged_columns
from selfright.train.checkpoints import read_meta
from selfright.train.commands import load_checkpoint_actor
from selfright.train.config import DistillationConfig, TrainConfig
from selfright.train.contexts import make_training_worlds
from selfright.train.vecenv import RecoveryVecEnv


@dataclass(frozen=True)
class Args:
    checkpoint: Path
    """A distillation checkpoint (or run folder) of a student with a velocity estimator."""
    context: str = "incline"
    """Training context to roll out in."""
    envs: int = 64
    """Parallel episodes."""
    steps: int = 1000
    """Control steps (50 Hz) of every env; episodes restart as in training."""
    seed: int = 7
    """Seed of the episodes."""


def main(args: Args) -> None:
    actor, ckpt = load_checkpoint_actor(args.checkpoint)
    if actor.estimator is None:
        raise SystemExit(f"estimator_accuracy: {ckpt} has no velocity estimator (train with --train.distillation.velocity-estimator)")
    pol = read_meta(ckpt.parent).get("policy") or {}
    bench = BenchmarkConfig(action=ActionConfig(reference=pol.get("action_reference", "stand")))
    train = TrainConfig(distillation=DistillationConfig(student_history=actor.meta.obs_history))
    env = RecoveryVecEnv(bench, train, make_training_worlds(args.context, bench, args.seed), args.envs, seed=args.seed)
    group = "student_history" if actor.meta.obs_history > 1 else "student"
    cols = privileged_columns(env.num_actions)["velocity"]
    est, true = [], []
    with torch.no_grad():
        for _ in tqdm(range(args.steps), desc="rollout"):
            obs = env.get_observations()
            x = obs[group]
            est.append(actor.estimate_rows(x))
            true.append(obs["teacher"][:, cols])
            env.step(actor(x))
    env.close()
    e, t = torch.cat(est), torch.cat(true)
    mse = (e - t).pow(2).mean(0)
    var = t.var(0, unbiased=False)
    print(f"{len(t):,} states of {ckpt} on {args.context} (seed {args.seed})")
    for i, axis in enumerate("xyz"):
        print(f"  v_{axis}: true std {var[i].sqrt():.3f} m/s, RMS error {mse[i].sqrt():.3f} m/s, R² {1 - mse[i] / var[i]:.3f}")
    print(f"  all: mean squared error {mse.mean():.4f} (m/s)², R² {1 - mse.sum() / var.sum():.3f}")


if __name__ == "__main__":
    main(tyro.cli(Args))
