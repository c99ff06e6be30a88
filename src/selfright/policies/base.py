"""The policy interface every evaluated or trained controller plugs into."""

from __future__ import annotations

import abc
import hashlib
from collections.abc import Sequence

import numpy as np
import torch

from selfright.terrain import Cell


class Policy(abc.ABC):
    """A batched controller.

    ``act`` maps the observation groups of k envs to k actions; joint targets are then
    ``reference + ActionConfig.scale_rad · action``, the reference being the standing pose or
    the current joint angles (``ActionConfig.reference``; see ``RecoveryEnv._targets``).
    ``ids`` identify the env slots (for policies that keep per-episode memory) and
    ``cells`` are the terrain cells the envs run on (``selfright.terrain.Cell``, None outside an
    evaluation grid), which only the ``sr`` multiplexer reads.
    """

    name: str = "policy"
    groups: tuple[str, ...] = ("student", "teacher")
    """Observation groups ``act`` reads (the env computes only these)."""
    action_mapping: tuple[str, float] | None = None
    """(``ActionConfig.reference``, ``scale_rad``) its actions were trained for; None if not
    recorded (baselines convert their targets for any mapping)."""
    digest: str | None = None
    """Short SHA-256 of the weights it acts with (the files it was loaded from), recorded in an
    evaluation's ``run.json`` so that a resumed run refuses results of other weights under
    the same name; None for policies that are code only."""

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None = None) -> None:  # noqa: B027 - optional hook
        """Forget per-episode memory of slots ``ids`` (called when their episodes start).

        ``seeds`` (k,) are the episodes' seeds, for policies that draw random numbers: a
        stochastic policy must seed per episode so results do not depend on batching.
        """

    @abc.abstractmethod
    def act(self, obs: dict[str, torch.Tensor], ids: np.ndarray, cells: Sequence[Cell | None]) -> torch.Tensor:
        """(k, J) actions for the k envs whose observations are given."""


class CallablePolicy(Policy):
    """Wraps a plain callable ``f(obs: Tensor (k, D)) -> Tensor (k, J)`` reading one group."""

    def __init__(self, fn, group: str = "student", name: str = "callable"):
        self.fn = fn
        self.group = group
        self.name = name

    @torch.no_grad()
    def act(self, obs, ids, cells):
        return torch.as_tensor(self.fn(obs[self.group]), dtype=torch.float32)


def combined_digest(policies: Sequence[Policy]) -> str | None:
    """One digest for a policy made of others (None if none of them has weights)."""
    parts = [p.digest or "" for p in policies]
    if not any(parts):
        return None
    return hashlib.sha256("/".join(parts).encode()).hexdigest()[:16]
