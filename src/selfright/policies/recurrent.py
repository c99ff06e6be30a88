"""Per-slot hidden state of a recurrent policy, zeros at each episode's start.

Deployment keeps one GRU state per env slot (``selfright.policies.learned``), the way rsl_rl's
``RNN`` keeps one per env in training and zeroes the slots whose episodes ended.
"""

from __future__ import annotations

import numpy as np
import torch

from selfright.policies.slots import grown, slot_index


class HiddenStates:
    """(slots, dim) hidden states; grows to any slot index."""

    def __init__(self, dim: int, slots: int = 0):
        if dim < 1:
            raise ValueError(f"a hidden state needs at least 1 unit (got {dim})")
        self.dim = dim
        self.buf = torch.zeros(slots, dim)

    def _slots(self, ids: np.ndarray) -> torch.Tensor:
        """``ids`` as an index tensor, the buffer grown to hold every one of them."""
        t = slot_index(ids)
        self.buf = grown(self.buf, t)
        return t

    def reset(self, ids: np.ndarray) -> None:
        """Slots ``ids`` (k,) start new episodes: their state is zeros."""
        t = self._slots(ids)  # before reading self.buf: it may grow
        self.buf[t] = 0.0

    def get(self, ids: np.ndarray) -> torch.Tensor:
        """The states of slots ``ids``: (k, dim)."""
        t = self._slots(ids)
        return self.buf[t].clone()

    def set(self, ids: np.ndarray, states: torch.Tensor) -> None:
        """Store ``states`` (k, dim) as the states of slots ``ids``."""
        t = self._slots(ids)
        self.buf[t] = states.detach().to(self.buf.dtype).cpu()
