"""Per-slot hidden state of a recurrent policy, zeros at each episode's start.

Deployment keeps one GRU state per env slot (``selfright.policies.learned``), the way rsl_rl's
``RNN`` keeps one per env in training and zeroes the slots whose episodes ended.
"""

from __future__ import annotations

import numpy as np
import torch


class HiddenStates:
    """(slots, dim) hidden states; grows to any slot index."""

    def __init__(self, dim: int, slots: int = 0):
        if dim < 1:
            raise ValueError(f"a hidden state needs at least 1 unit (got {dim})")
        self.dim = dim
        self.buf = torch.zeros(slots, dim)

    def _grow(self, slots: int) -> None:
        n = self.buf.shape[0]
        if slots > n:
            self.buf = torch.cat([self.buf, torch.zeros(slots - n, self.dim)])

    def reset(self, ids: np.ndarray) -> None:
        """Slots ``ids`` (k,) start new episodes: their state is zeros."""
        t = torch.as_tensor(np.asarray(ids), dtype=torch.long)
        if len(t):
            self._grow(int(t.max()) + 1)
            self.buf[t] = 0.0

    def get(self, ids: np.ndarray) -> torch.Tensor:
        """The states of slots ``ids``: (k, dim)."""
        t = torch.as_tensor(np.asarray(ids), dtype=torch.long)
        if len(t):
            self._grow(int(t.max()) + 1)
        return self.buf[t].clone()

    def set(self, ids: np.ndarray, states: torch.Tensor) -> None:
        """Store ``states`` (k, dim) as the states of slots ``ids``."""
        t = torch.as_tensor(np.asarray(ids), dtype=torch.long)
        if len(t):
            self._grow(int(t.max()) + 1)
            self.buf[t] = states.detach().to(self.buf.dtype).cpu()
