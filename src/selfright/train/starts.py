"""Episode starts of the training env: drawn (world, fall, randomisation), settled, and
possibly kept per slot until the slot's current episode ends (``EpisodeConfig.prepare_starts``).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import torch

from selfright.env.recovery_env import SettledStarts


@dataclass(frozen=True)
class EpisodeDraw:
    """k drawn and settled episode starts, rows aligned."""

    world_idx: np.ndarray
    """(k,) world (tile) of each episode."""
    models: list[mujoco.MjModel]
    """k models the episodes run on (randomised copies or the worlds' own)."""
    factors: torch.Tensor
    """(k, 3) mass, Kp, Kd scales (ones without randomisation)."""
    friction: torch.Tensor
    """(k,) ground friction the teacher observes."""
    replayed: np.ndarray
    """(k,) bool, the fall replays a recent failed episode's draw."""
    origins: list[tuple[int, np.random.Generator] | None]
    """(world, generator before the fall draw) of each episode, kept for replay (else None)."""
    settled: SettledStarts
    """States after the fall protocol's 2 s settle."""


class PreparedStarts:
    """One settled next start per slot (or none: ``ready`` false)."""

    def __init__(self, num_envs: int, state_size: int, sensor_size: int):
        self.ready = np.zeros(num_envs, dtype=bool)
        self.world = np.zeros(num_envs, dtype=np.int64)
        self.models: list[mujoco.MjModel | None] = [None] * num_envs
        self.factors = torch.ones(num_envs, 3)
        self.friction = torch.ones(num_envs)
        self.replayed = np.zeros(num_envs, dtype=bool)
        self.origins: list[tuple[int, np.random.Generator] | None] = [None] * num_envs
        self.state = np.zeros((num_envs, state_size))
        self.sens = np.zeros((num_envs, sensor_size))
        self.diverged = np.zeros(num_envs, dtype=bool)

    def put(self, slots: np.ndarray, draw: EpisodeDraw) -> None:
        """Keep ``draw``'s rows as the next starts of ``slots``."""
        t = torch.from_numpy(slots)
        self.world[slots] = draw.world_idx
        self.factors[t] = draw.factors
        self.friction[t] = draw.friction
        self.replayed[slots] = draw.replayed
        self.state[slots] = draw.settled.state
        self.sens[slots] = draw.settled.sens
        self.diverged[slots] = draw.settled.diverged
        for j, i in enumerate(slots):
            self.models[i] = draw.models[j]
            self.origins[i] = draw.origins[j]
        self.ready[slots] = True

    def take(self, slots: np.ndarray) -> EpisodeDraw:
        """Hand out the (ready) next starts of ``slots`` and mark them used."""
        if not self.ready[slots].all():
            raise RuntimeError("a slot has no prepared start")
        t = torch.from_numpy(slots)
        models = [self.models[i] for i in slots]
        draw = EpisodeDraw(
            world_idx=self.world[slots].copy(),
            models=models,  # type: ignore[arg-type]
            factors=self.factors[t].clone(),
            friction=self.friction[t].clone(),
            replayed=self.replayed[slots].copy(),
            origins=[self.origins[i] for i in slots],
            settled=SettledStarts(
                state=self.state[slots].copy(), sens=self.sens[slots].copy(), diverged=self.diverged[slots].copy()
            ),
        )
        self.ready[slots] = False
        for i in slots:
            self.models[i] = None
            self.origins[i] = None
        return draw
