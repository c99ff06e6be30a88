"""How well a student's trunk-velocity estimator (``--train.distillation.velocity-estimator``)
tracks the true body-frame velocity on its own rollouts in the training env (falls, settling,
domain randomisation as in training; the student acts with its mean action): RMS error and
R² per axis, and the spread of the true velocity. Any student (one without an estimator too)
also gets a linear probe: how much of the velocity a least-squares fit reads off its last
hidden layer (fitted on three quarters of the envs, scored on the rest), i.e. how much of it
the network represents on its own.

``--target`` picks the privileged quantity instead of the velocity: ``height`` (trunk height
above the ground beneath it) or ``bump`` (the ground beneath the trunk above the mean of the
height scan's 0.6 m square around it: what a robot standing on a rough tile cannot read from its
legs' kinematics). R² is also reported over the upright states alone (trunk within 30° of
vertical), where the goal set's height bar is decided.

With ``--fit-histories H ...`` it also asks what the student's sensors allow: fresh estimators
of the same network, each reading the last H student frames, are fitted offline to the same
rollouts (three quarters of the envs) and scored on the rest, so a longer history or another
network can be judged without training a student.

    python scripts/estimator_accuracy.py --checkpoint runs/incline_student_vel/model_299.pt --context incline
    python scripts/estimator_accuracy.py --checkpoint runs/incline_student_vel/model_299.pt --fit-histories 1 5 25 50 100
    python scripts/estimator_accuracy.py --checkpoint runs/incline_student_tilt45_big/model_299.pt   # probe only
    python scripts/estimator_accuracy.py --checkpoint runs/gpu_rough_h25w/model_721.pt --context rough --target bump --fit-histories 1 25 50
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Literal

import torch
import tyro
from tqdm import tqdm

from selfright.config import ActionConfig, BenchmarkConfig
from selfright.env.observations import privileged_columns
from selfright.policies.actor import mlp_layers
from selfright.train.checkpoints import read_meta
from selfright.train.commands import load_checkpoint_actor
from selfright.train.config import DistillationConfig, TrainConfig
from selfright.train.contexts import make_training_worlds
from selfright.train.vecenv import RecoveryVecEnv


@dataclass(frozen=True)
class Args:
    checkpoint: Path
    """A distillation checkpoint (or run folder) of a student, with or without a velocity estimator."""
    context: str = "incline"
    """Training context to roll out in."""
    envs: int = 64
    """Parallel episodes."""
    steps: int = 1000
    """Control steps (50 Hz) of every env; episodes restart as in training."""
    seed: int = 7
    """Seed of the episodes."""
    fit_histories: tuple[int, ...] = ()
    """Frames of student observation history of estimators fitted offline to the rollouts."""
    fit_dims: tuple[int, ...] = (256, 128)
    """Hidden widths of those estimators."""
    fit_epochs: int = 30
    """Passes over the fitting envs' states."""
    target: Literal["velocity", "height", "bump"] = "velocity"
    """Privileged quantity to estimate (a student's own estimator, if any, is scored on the
    velocity only)."""


UPRIGHT_COS = math.cos(math.radians(30.0))
"""Upright states: trunk up axis within 30° of world z (the goal set bounds roll and pitch by 30° each)."""


def target_values(teacher_obs: torch.Tensor, num_joints: int, target: str) -> torch.Tensor:
    """(k, d) the privileged ``target`` read off teacher observations (k, D)."""
    cols = privileged_columns(num_joints)
    if target == "velocity":
        return teacher_obs[:, cols["velocity"]]
    height = teacher_obs[:, cols["height"]]
    if target == "height":
        return height
    return teacher_obs[:, cols["scan"]].mean(-1, keepdim=True) - height  # ground beneath - mean ground around


def main(args: Args) -> None:
    actor, ckpt = load_checkpoint_actor(args.checkpoint)
    if actor.recurrent:
        raise SystemExit(f"estimator_accuracy: {ckpt} is a recurrent student; it reads feed-forward ones")
    pol = read_meta(ckpt.parent).get("policy") or {}
    bench = BenchmarkConfig(action=ActionConfig(reference=pol.get("action_reference", "stand")))
    if actor.meta.motor == "dcmotor":  # roll out on the motors it trained with
        bench = replace(bench, robot=replace(bench.robot, motor="dcmotor",
                                             motor_speed_rad_s=actor.meta.motor_speed_rad_s or None))
    train = TrainConfig(distillation=DistillationConfig(student_history=actor.meta.obs_history))
    env = RecoveryVecEnv(bench, train, make_training_worlds(args.context, bench, args.seed), args.envs, seed=args.seed)
    group = "student_history" if actor.meta.obs_history > 1 else "student"
    est, hidden, true, frames, starts, vel = [], [], [], [], [], []
    last_hidden = actor.mlp[:-1]
    fresh = torch.ones(args.envs, dtype=torch.bool)
    with torch.no_grad():
        for _ in tqdm(range(args.steps), desc="rollout"):
            obs = env.get_observations()
            x = obs[group]
            z = actor._normalize(x)
            if actor.estimator is not None:
                est.append(actor.estimate_rows(x))
                vel.append(target_values(obs["teacher"], env.num_actions, "velocity"))
                z = torch.cat([z, est[-1]], dim=-1)
            hidden.append(last_hidden(z))
            true.append(target_values(obs["teacher"], env.num_actions, args.target))
            frames.append(obs["student"])
            starts.append(fresh)
            _, _, dones, _ = env.step(actor(x))
            fresh = dones.bool().cpu()
    env.close()
    t = torch.cat(true)
    f, st = torch.stack(frames), torch.stack(starts)  # (T, N, ...)
    upright = f[..., 2] < -UPRIGHT_COS  # projected gravity's z: the IMU's tilt
    print(f"{len(t):,} states of {ckpt} on {args.context} (seed {args.seed}), "
          f"{upright.float().mean():.1%} upright; target {args.target}: std {t.std(0, unbiased=False).tolist()}")
    if est:
        v = torch.cat(vel)
        var = v.var(0, unbiased=False)
        mse = (torch.cat(est) - v).pow(2).mean(0)
        for i, axis in enumerate("xyz"):
            print(f"  v_{axis}: true std {var[i].sqrt():.3f} m/s, RMS error {mse[i].sqrt():.3f} m/s, R² {1 - mse[i] / var[i]:.3f}")
        print(f"  all: mean squared error {mse.mean():.4f} (m/s)², R² {1 - mse.sum() / var.sum():.3f}")
    else:
        print("  (no velocity estimator)")
    y = torch.stack(true)
    r2, r2_up = linear_probe(torch.stack(hidden), y, upright)
    print(f"linear probe of the last hidden layer ({hidden[0].shape[-1]} units), R² on held-out envs "
          f"(per output / all; upright states: all): {_r2_text(r2)}; {r2_up[-1]:.3f}")
    if args.fit_histories:
        print(f"estimators fitted offline ({'-'.join(map(str, args.fit_dims))} units, {args.fit_epochs} epochs), "
              f"R² on held-out envs (per output / all; upright states: all):")
        for h in args.fit_histories:
            r2, r2_up = fit_offline(stacked(f, st, h), y, upright, args.fit_dims, args.fit_epochs, args.seed)
            print(f"  {h:4d} frames: {_r2_text(r2)}; {r2_up[-1]:.3f}")


def _r2_text(r2: list[float]) -> str:
    per = r2[:-1] if len(r2) > 2 else []
    return (", ".join(f"{r:.3f}" for r in per) + " / " if per else "") + f"{r2[-1]:.3f}"


def stacked(frames: torch.Tensor, starts: torch.Tensor, h: int) -> torch.Tensor:
    """(T, N, h·F) the last ``h`` frames at every step, oldest first, an episode's first frame
    repeated before it (``selfright.policies.history``'s rule)."""
    t_len, n = starts.shape
    begin = torch.zeros(t_len, n, dtype=torch.long)
    for t in range(t_len):
        begin[t] = torch.where(starts[t], torch.full((n,), t), begin[t - 1] if t else torch.zeros(n, dtype=torch.long))
    steps = torch.arange(t_len)[:, None]
    idx = [torch.maximum(steps - k, begin) for k in range(h - 1, -1, -1)]
    env = torch.arange(n)[None, :]
    return torch.cat([frames[i, env] for i in idx], dim=-1)


def held_out_r2(pred: torch.Tensor, y: torch.Tensor) -> list[float]:
    """R² of ``pred`` against ``y`` (k, d) per output, then overall (NaN for no states)."""
    if len(y) == 0:
        return [math.nan] * (y.shape[-1] + 1)
    err = (pred - y).pow(2).mean(0)
    var = y.var(0, unbiased=False)
    return [*(1 - err / var).tolist(), float(1 - err.sum() / var.sum())]


def split_envs(x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(T, N, ...) -> the first three quarters of the envs' samples, and the rest's."""
    split = 3 * x.shape[1] // 4
    return x[:, :split].flatten(0, 1), x[:, split:].flatten(0, 1)


def held_out_scores(pred: torch.Tensor, y: torch.Tensor, upright: torch.Tensor) -> tuple[list[float], list[float]]:
    """``held_out_r2`` over all held-out states, and over the upright ones (``upright`` (k,) bool)."""
    return held_out_r2(pred, y), held_out_r2(pred[upright], y[upright])


def linear_probe(h: torch.Tensor, y: torch.Tensor, upright: torch.Tensor) -> tuple[list[float], list[float]]:
    """Least-squares fit ``y ≈ [h, 1] W`` on the fitting envs, R² on the held-out ones (all, upright)."""
    (htr, hte), (ytr, yte) = split_envs(h), split_envs(y)
    ones = lambda a: torch.cat([a, torch.ones(len(a), 1)], dim=-1)  # noqa: E731
    w = torch.linalg.lstsq(ones(htr).double(), ytr.double()).solution
    return held_out_scores((ones(hte).double() @ w).float(), yte, split_envs(upright)[1])


def fit_offline(x: torch.Tensor, y: torch.Tensor, upright: torch.Tensor, dims: tuple[int, ...], epochs: int,
                seed: int) -> tuple[list[float], list[float]]:
    """Fit an MLP ``x -> y`` on the first three quarters of the envs (axis 1), score R² per
    output and overall on the rest, over all its states and the upright ones (``upright`` (T, N))."""
    from torch import nn

    (xtr, xte), (ytr, yte) = split_envs(x), split_envs(y)
    mean, std = xtr.mean(0), xtr.std(0) + 1e-2
    g = torch.Generator().manual_seed(seed)
    torch.manual_seed(seed)
    net = mlp_layers(x.shape[-1], dims, y.shape[-1], "elu")
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    for _ in range(epochs):
        for batch in torch.randperm(len(xtr), generator=g).split(1024):
            loss = nn.functional.mse_loss(net((xtr[batch] - mean) / std), ytr[batch])
            opt.zero_grad()
            loss.backward()
            opt.step()
    with torch.no_grad():
        return held_out_scores(net((xte - mean) / std), yte, split_envs(upright)[1])


if __name__ == "__main__":
    main(tyro.cli(Args))
