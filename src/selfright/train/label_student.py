"""A student that labels another: loading it, and the training config its network implies
(``selfright train --role student --teacher STUDENT``, the stance distillation).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from selfright.policies.actor import ActorMLP
from selfright.policies.learned import load_torch_actor
from selfright.policies.registry import shipped_path
from selfright.policies.run_files import latest_checkpoint
from selfright.train.config import TrainConfig

__all__ = ["is_student", "load_student", "student_train_config"]


def load_student(path: Path, flag: str = "--init-from") -> ActorMLP:
    """A distilled student: a student run folder or ``model_<it>.pt``, a policy
    file from ``selfright export``, or a shipped policy name (``incline``). ``ValueError`` if it
    is not a student."""
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
    return actor


def is_student(path: Path) -> bool:
    """Whether ``path`` (a run folder, a checkpoint or a policy file) holds a student (an actor
    on the ``student`` observations), not a teacher."""
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
                                   obs_normalization=m.obs_normalization),
        distillation=dataclasses.replace(train.distillation, student_history=m.obs_history),
    )
