"""π_SR: per env, the specialised policy of the training context its terrain cell is closest to."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from selfright.policies.base import Policy, combined_digest
from selfright.terrain import Cell

CONTEXTS = ("flat", "rough", "incline")
"""The training contexts, one specialised member each."""
INCLINE_SWITCH_DEG = 15.0
"""Cells sloped at least this much go to π_INCLINE (its 20° training slope is the nearest)..."""
INCLINE_ROUGHNESS_BELOW = 7
"""... when their roughness level is below this; rougher sloped cells go to π_ROUGH."""


def sr_context(slope_deg: float, roughness_level: int, switch_deg: float = INCLINE_SWITCH_DEG,
               roughness_below: int = INCLINE_ROUGHNESS_BELOW) -> str:
    """The member π_SR picks for a cell of this slope (deg) and roughness level.

    Rule (a documented choice; the seed leaves the switch implicit): cells sloped at least
    ``switch_deg`` with roughness level below ``roughness_below`` use π_INCLINE, else cells with
    roughness level ≥ 1 use π_ROUGH, else π_FLAT. The roughness cut was chosen on the members'
    own evaluations on the paper grid with seed 1 (26.9 % against 24.6 % for π_INCLINE at every
    roughness) and checked on seed 0 (docs/benchmark.md, *π_SR and its hand-over rule*).
    """
    if slope_deg >= switch_deg and roughness_level < roughness_below:
        return "incline"
    return "rough" if roughness_level >= 1 else "flat"


def cell_context(cell: Cell | None) -> str | None:
    """``sr_context`` of a grid cell; None for an env outside any grid."""
    return None if cell is None else sr_context(cell.slope_deg, cell.roughness_level)


class ContextMultiplexer(Policy):
    """π_SR = π_FLAT on c_FLAT, π_ROUGH on c_ROUGH, π_INCLINE on c_INCLINE.

    ``policies`` maps each context to its member; an env's context is ``cell_context`` of its
    cell, and envs without a cell (or of a context with no member) use ``default``.
    """

    name = "sr"

    def __init__(self, policies: dict[str, Policy], default: str = "flat"):
        self.policies = policies
        self.default = default
        self.digest = combined_digest([policies[k] for k in sorted(policies)])

    def reset(self, ids, seeds=None):
        for p in self.policies.values():
            p.reset(ids, seeds)

    @torch.no_grad()
    def act(self, obs: dict[str, torch.Tensor], ids: np.ndarray, cells: Sequence[Cell | None]) -> torch.Tensor:
        picks = [cell_context(c) for c in cells]
        ctx = np.array([c if c in self.policies else self.default for c in picks])
        out = None
        for name, pol in self.policies.items():
            rows = np.nonzero(ctx == name)[0]
            if len(rows) == 0:
                continue
            sel = torch.from_numpy(rows)
            a = pol.act({k: v[sel] for k, v in obs.items()}, np.asarray(ids)[rows], [cells[i] for i in rows])
            if out is None:
                out = torch.zeros(len(ctx), a.shape[1])
            out[sel] = a
        assert out is not None
        return out
