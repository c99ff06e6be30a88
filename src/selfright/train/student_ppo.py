"""PPO on a distilled student (``selfright train --role student-ppo``).

Distillation copies what a teacher does; where the teacher leans on what only it observes
(the incline teacher's upright phase reads the trunk velocity), the student copies it badly
and nothing in behaviour cloning tells it what *it* should do instead. This role goes on from
a distilled student with PPO under the same Table I reward:

* the **actor** is the student (its network, observation group, frames of history and
  normaliser, copied exactly from ``--init-from``), so what trains is what deploys on the
  A1's own sensors;
* the **critic** reads the privileged ``teacher`` group (an asymmetric actor-critic) and starts
  as the ``--teacher`` run's trained critic, a value function of the same reward in the same
  episodes, so the first policy updates are not driven by a random baseline;
* the **action noise** starts at the teacher's learned per-joint std (the distilled student's
  own std is never trained).

Its checkpoints record ``role: student`` and the student's group and history, so they
evaluate, export and ship like any other student.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import torch

from selfright.policies.actor import ActorMLP, teacher_checkpoint
from selfright.policies.learned import load_torch_actor
from selfright.policies.registry import shipped_path
from selfright.train.checkpoints import latest_checkpoint
from selfright.train.config import TrainConfig

__all__ = ["is_student", "load_student", "student_train_config", "student_ppo_start", "attach_critic_warmup"]


def load_student(path: Path, flag: str = "--init-from") -> ActorMLP:
    """The distilled student to start from: a student run folder or ``model_<it>.pt``, a policy
    file from ``selfright export``, or a shipped policy name (``incline``). ``ValueError`` if it
    is not a feed-forward student."""
    p = path if path.exists() else shipped_path(str(path))
    if not p.exists():
        raise ValueError(f"{flag} {path}: neither a run, a checkpoint, a policy file nor a shipped policy name")
    if p.is_dir():
        p = latest_checkpoint(p)
    actor = load_torch_actor(p)
    m = actor.meta
    if m.obs_group != "student":
        raise ValueError(f"{flag} {p} reads the {m.obs_group!r} observations; it must be a student "
                         "(a teacher goes on training with --role teacher --init-from)")
    if actor.recurrent or actor.estimator is not None:
        raise ValueError(f"{flag} {p}: only feed-forward students (no GRU, no velocity estimator) here")
    return actor


def is_student(path: Path) -> bool:
    """Whether ``path`` (a run folder, a checkpoint or a policy file) holds a feed-forward or any
    other student (an actor on the ``student`` observations), not a teacher."""
    try:
        return load_torch_actor(latest_checkpoint(path) if path.is_dir() else path).meta.obs_group == "student"
    except ValueError:
        return False


def student_train_config(train: TrainConfig, student: ActorMLP) -> TrainConfig:
    """``train`` with the actor network and the student's history set to ``student``'s, so
    rsl_rl builds an actor its weights fit and the env stacks the frames it reads."""
    m = student.meta
    return dataclasses.replace(
        train,
        policy=dataclasses.replace(train.policy, hidden_dims=tuple(m.hidden_dims), activation=m.activation,
                                   obs_normalization=m.obs_normalization, state_dependent_std=False),
        distillation=dataclasses.replace(train.distillation, student_history=m.obs_history, student_gru=0,
                                         velocity_estimator=()),
    )


def student_ppo_start(student: ActorMLP, teacher_ckpt: dict[str, Any]) -> dict[str, Any]:
    """The rsl_rl PPO state to start from: the student as the actor (its normaliser counted as
    the teacher's, so PPO's running statistics move it as slowly), the teacher's critic, and
    the teacher's action std."""
    critic = teacher_ckpt.get("critic_state_dict")
    actor_sd = teacher_ckpt.get("actor_state_dict") or {}
    std = actor_sd.get("distribution.std_param")
    if critic is None or std is None:
        raise ValueError("--teacher must be a PPO run checkpoint with its critic and a state-independent action std "
                         "(a shipped or converted teacher has no critic)")
    actor = teacher_checkpoint(student)["actor_state_dict"]
    if std.shape != actor["distribution.std_param"].shape:
        raise ValueError(f"--teacher acts on {std.numel()} joints, the student on {actor['distribution.std_param'].numel()}")
    actor["distribution.std_param"] = std.detach().clone()
    if "obs_normalizer.count" in actor:
        actor["obs_normalizer.count"] = actor_sd.get("obs_normalizer.count", torch.tensor(10**6)).clone()
    return {"actor_state_dict": actor, "critic_state_dict": critic}


def attach_critic_warmup(alg: Any, iterations: int) -> None:
    """Make the next ``iterations`` PPO updates of ``alg`` (rsl_rl ``PPO``) train the critic
    only: the actor's parameters stop requiring gradients during each of them, so the optimiser
    skips them, their KL is 0 and the adaptive learning rate holds."""
    if iterations <= 0:
        return
    update, left = alg.update, [iterations]

    def warm_update() -> dict[str, float]:
        if left[0] <= 0:
            return update()
        left[0] -= 1
        params = list(alg.actor.parameters())
        flags = [p.requires_grad for p in params]
        for p in params:
            p.requires_grad_(False)
        try:
            return update()
        finally:
            for p, flag in zip(params, flags):
                p.requires_grad_(flag)

    alg.update = warm_update
