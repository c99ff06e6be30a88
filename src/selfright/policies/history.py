"""A short observation history: the last H frames of one observation group, oldest first.

Training (``selfright.train.vecenv``) and deployment (``selfright.policies.learned``) stack
frames with this one class, so a student trained on H frames is evaluated on the same input.
At an episode's first step every frame holds that step's observation (nothing from before
the episode, no zeros the robot never sensed).
"""

from __future__ import annotations

import numpy as np
import torch

from selfright.policies.slots import grown, slot_index


class ObsHistory:
    """Per-slot ring of ``frames`` observations of size ``dim``; grows to any slot index."""

    def __init__(self, frames: int, dim: int, slots: int = 0):
        if frames < 1:
            raise ValueError(f"an observation history needs at least 1 frame (got {frames})")
        self.frames = frames
        self.dim = dim
        self.buf = torch.zeros(slots, frames, dim)
        self.fresh = torch.ones(slots, dtype=torch.bool)
        """Slots whose next ``push`` starts an episode (fills every frame)."""

    def _slots(self, ids: np.ndarray) -> torch.Tensor:
        """``ids`` as an index tensor, the buffers grown to hold every one of them."""
        t = slot_index(ids)
        self.buf, self.fresh = grown(self.buf, t), grown(self.fresh, t, True)
        return t

    def reset(self, ids: np.ndarray) -> None:
        """Slots ``ids`` (k,) start new episodes: their next frame fills the whole history."""
        t = self._slots(ids)  # before reading self.fresh: it may grow
        self.fresh[t] = True

    def push(self, ids: np.ndarray, obs: torch.Tensor) -> torch.Tensor:
        """Append ``obs`` (k, dim) to the histories of slots ``ids``; returns the stacked
        histories (k, frames · dim), oldest frame first."""
        t = self._slots(ids)
        if len(t) == 0:
            return obs.new_zeros(0, self.frames * self.dim)
        x = obs.detach().to(self.buf.dtype).cpu()
        rolled = torch.cat([self.buf[t, 1:], x[:, None]], dim=1)
        filled = x[:, None].expand(-1, self.frames, -1)
        new = torch.where(self.fresh[t][:, None, None], filled, rolled)
        self.buf[t] = new
        self.fresh[t] = False
        return new.reshape(len(t), -1).to(obs.device, obs.dtype)
