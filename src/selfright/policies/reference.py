"""Running a policy under another fixed action reference than the one it was trained with.

Joint targets are ``pose + scale · action`` (``ActionConfig``). A policy trained around pose A
acts identically in an env that maps actions around pose B once its actions are shifted by
(A − B) / scale and the previous action it observes is its own, in its own units
(``ShiftedReference``; on an episode's first step the env reports "no previous action" as 0 in
any units). So
``stand`` and ``tall`` policies (and a multiplexer holding both) run in either env, and the
benchmark's action mapping need not change with the policy. ``current`` (targets relative to
the angles at each step) is no fixed pose and cannot be converted.
"""

from __future__ import annotations

import numpy as np
import torch

from selfright.config import ActionConfig
from selfright.env.observations import prev_action_columns
from selfright.policies.base import Policy
from selfright.policies.slots import grown, slot_index
from selfright.robots import RobotSpec


def reference_offset(robot: RobotSpec, trained: tuple[str, float | None], action: ActionConfig) -> np.ndarray | None:
    """(J,) offset, in action units, that converts a policy trained with the action mapping
    ``trained`` (reference, scale; a falsy scale = unknown, taken as ``action``'s) to an env
    mapping actions by ``action``: (pose A − pose B) / scale. None when the two mappings are the
    same; ``ValueError`` when no fixed offset converts (``current``, or another scale)."""
    ref, scale = trained
    same_scale = not scale or abs(scale - action.scale_rad) <= 1e-9
    if ref == action.reference and same_scale:
        return None
    if not same_scale or "current" in (ref, action.reference):
        raise ValueError(f"actions around {ref!r} at {scale} rad do not convert to {action.reference!r} at {action.scale_rad} rad")
    return (robot.reference_pose(ref) - robot.reference_pose(action.reference)) / action.scale_rad


class ShiftedReference(Policy):
    """``inner`` (trained around pose A) in an env whose action 0 is pose B.

    It observes its previous action as in training: its own action clipped to ±``clip`` in its
    own units (the env clips the shifted action in the env's units, which differs once an action
    saturates). The joint targets agree as well: where the env's clip binds, both targets lie
    beyond the joint range (B ± 0.5 rad × clip covers it on the A1) and are held to the same limit.

    Args:
        inner: the policy.
        offset: (J,) (A − B) / scale, in action units.
        env_mapping: the env's (reference, scale).
        clip: the action clip (``ActionConfig.clip``).
    """

    def __init__(self, inner: Policy, offset: np.ndarray, env_mapping: tuple[str, float], clip: float):
        self.inner = inner
        self.name = inner.name
        self.groups = inner.groups
        self.digest = inner.digest  # the weights are the inner policy's
        self.action_mapping = env_mapping
        self.offset = torch.as_tensor(offset, dtype=torch.float32)
        self.clip = float(clip)
        self.last = torch.zeros(0, len(self.offset))
        """Each slot's previous action, clipped, in the inner policy's units."""
        self.took = torch.zeros(0, dtype=torch.bool)
        """Slots whose episode has taken a step."""

    def __getattr__(self, item: str):
        """Everything else (``group``, the network, ...) is the inner policy's."""
        inner = self.__dict__.get("inner")
        if inner is None:
            raise AttributeError(item)
        return getattr(inner, item)

    def reset(self, ids, seeds=None):
        t = slot_index(np.asarray(ids))
        self.last, self.took = grown(self.last, t), grown(self.took, t, False)
        self.took[t] = False
        self.inner.reset(ids, seeds)

    @torch.no_grad()
    def act(self, obs, ids, cells):
        t = slot_index(np.asarray(ids))
        self.last, self.took = grown(self.last, t), grown(self.took, t, False)
        took, cols = self.took[t], prev_action_columns(len(self.offset))
        shifted = {}
        for group, x in obs.items():
            x = x.clone()
            rows = took.nonzero().flatten()
            x[rows, cols] = self.last[t[rows]].to(x.device, x.dtype)
            shifted[group] = x
        a = self.inner.act(shifted, ids, cells).clamp(-self.clip, self.clip)
        self.last[t] = a.detach().cpu().float()
        self.took[t] = True
        return a + self.offset.to(a.device, a.dtype)
