"""Episode starts of the training env: drawn (world, fall, randomisation), settled, and
possibly kept per slot until the slot's current episode ends (``EpisodeConfig.prepare_starts``).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from selfright.env.randomization import EpisodeFactors
from selfright.env.recovery_env import SettledStarts


@dataclass(frozen=True)
class EpisodeDraw:
    """k drawn and settled episode starts, rows aligned."""

    world_idx: np.ndarray
    """(k,) world (tile) of each episode."""
    factors: EpisodeFactors | None
    """Domain-randomisation factors of the episodes (None: randomisation off)."""
    models: list[mujoco.MjModel] | None
    """k models the episodes run on (randomised copies or the worlds' own); None = rebuild them
    from ``world_idx`` and ``factors`` (prepared starts do not keep a ~0.5 MB model copy each)."""
    settled: SettledStarts
    """States after the fall protocol's 2 s settle."""


class PreparedStarts:
    """One settled next start per slot (or none: ``ready`` false). Keeps the randomisation
    factors, not the models: ``take`` hands out draws whose models are to be rebuilt."""

    def __init__(self, num_envs: int, state_size: int, sensor_size: int):
        self.ready = np.zeros(num_envs, dtype=bool)
        self.world = np.zeros(num_envs, dtype=np.int64)
        self.randomized = False
        self.factors = np.ones((num_envs, 4))
        self.state = np.zeros((num_envs, state_size))
        self.sens = np.zeros((num_envs, sensor_size))
        self.diverged = np.zeros(num_envs, dtype=bool)

    def put(self, slots: np.ndarray, draw: EpisodeDraw) -> None:
        """Keep ``draw``'s rows as the next starts of ``slots``."""
        self.world[slots] = draw.world_idx
        self.randomized = draw.factors is not None
        if draw.factors is not None:
            self.factors[slots] = draw.factors.as_array()
        self.state[slots] = draw.settled.state
        self.sens[slots] = draw.settled.sens
        self.diverged[slots] = draw.settled.diverged
        self.ready[slots] = True

    def take(self, slots: np.ndarray) -> EpisodeDraw:
        """Hand out the (ready) next starts of ``slots`` and mark them used."""
        if not self.ready[slots].all():
            raise RuntimeError("a slot has no prepared start")
        draw = EpisodeDraw(
            world_idx=self.world[slots].copy(),
            factors=EpisodeFactors.from_array(self.factors[slots].copy()) if self.randomized else None,
            models=None,
            settled=SettledStarts(
                state=self.state[slots].copy(), sens=self.sens[slots].copy(), diverged=self.diverged[slots].copy()
            ),
        )
        self.ready[slots] = False
        return draw
