"""The seed's π_SR: picks the specialised policy by the context of each env's cell."""

from __future__ import annotations

import numpy as np
import torch

from selfright.policies.base import Policy, combined_digest


class ContextMultiplexer(Policy):
    """π_SR = π_FLAT on c_FLAT, π_ROUGH on c_ROUGH, π_INCLINE on c_INCLINE.

    The context of a grid cell is assigned by ``terrain.grid`` (see ``_context_of``).
    Cells without a context use ``default``.
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
    def act(self, obs, ids, contexts):
        ctx = np.array([c if c in self.policies else self.default for c in contexts])
        out = None
        for name, pol in self.policies.items():
            rows = np.nonzero(ctx == name)[0]
            if len(rows) == 0:
                continue
            sel = torch.from_numpy(rows)
            a = pol.act({k: v[sel] for k, v in obs.items()}, np.asarray(ids)[rows], [name] * len(rows))
            if out is None:
                out = torch.zeros(len(ctx), a.shape[1])
            out[sel] = a
        assert out is not None
        return out
