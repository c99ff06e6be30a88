"""Per-slot buffers of deployed policies: a tensor with one row per env slot that grows to
the largest slot index seen (evaluation hands out slot ids; training has a fixed number).
Used by ``ObsHistory``; ``SlotNoise``
draws per-episode Gaussian noise for ``NoisySensors``."""

from __future__ import annotations

import numpy as np
import torch


def slot_index(ids: np.ndarray | torch.Tensor) -> torch.Tensor:
    """Slot ids (k,), or a bool mask over all slots, as a CPU index tensor."""
    t = torch.as_tensor(ids)
    if t.dtype == torch.bool:
        t = t.nonzero().flatten()
    return t.to(dtype=torch.long, device="cpu")


def grown(buf: torch.Tensor, slots: torch.Tensor, fill: float | bool = 0) -> torch.Tensor:
    """``buf`` with rows of ``fill`` appended so that every index in ``slots`` is a row
    (``buf`` itself when it already is)."""
    n = int(slots.max()) + 1 if len(slots) else 0
    if n <= buf.shape[0]:
        return buf
    return torch.cat([buf, torch.full((n - buf.shape[0], *buf.shape[1:]), fill, dtype=buf.dtype)])


class SlotNoise:
    """Per env slot: a Gaussian generator seeded from the slot's episode seed and a fixed
    ``salt``, so a wrapper's noise depends on the episode, not on which batch or slot it ran in."""

    def __init__(self, *salt: int):
        self.salt = [int(x) for x in salt]
        self._rng: dict[int, np.random.Generator] = {}

    def reset(self, ids: np.ndarray, seeds: np.ndarray | None, who: str) -> None:
        if seeds is None:
            raise ValueError(f"{who} needs the episodes' seeds")
        for i, s in zip(np.asarray(ids).tolist(), np.asarray(seeds).tolist(), strict=True):
            self._rng[i] = np.random.default_rng([s, *self.salt])

    def draw(self, ids: np.ndarray, dim: int) -> torch.Tensor:
        """(k, dim) standard normal draws, one row per slot in ``ids``."""
        z = np.stack([self._rng[i].standard_normal(dim) for i in np.asarray(ids).tolist()])
        return torch.as_tensor(z, dtype=torch.float32)
