"""An exponential moving average of the student's weights during distillation.

The incline students' benchmark success swings by 20 points from one checkpoint to the next
(docs/training.md, *A composite that hands over by tilt*): each iteration's few Adam steps on
the student's own, ever-changing rollouts move a deterministic policy whose chaotic falls turn
small weight changes into other outcomes. Averaging the weights over the last tens of
iterations (Polyak averaging) is the standard remedy: the average moves slowly and sits in the
middle of the region the raw weights wander over.

The raw student keeps training as before (its weights stay ``student_state_dict``, so resuming
is unchanged); the average rides along in the checkpoint as ``student_ema_state_dict``, and
``selfright.policies.actor.actor_from_checkpoint`` deploys it when present. Only parameters
are averaged; buffers (the observation normaliser's running statistics) are copied from the
raw student, whose running average they already are.
"""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

EMA_KEY = "student_ema_state_dict"
"""Checkpoint key of the averaged student weights."""
EMA_COUNT_KEY = "student_ema_updates"
"""Checkpoint key of the number of averaging updates so far (for the warm-up)."""


class WeightAverage:
    """EMA of ``model``'s parameters, updated once per learning iteration.

    The effective decay warms up as min(decay, (1 + n) / (10 + n)) after n updates, so the
    random initial weights are forgotten within the first tens of iterations.

    Args:
        model: the module whose weights are averaged (the raw, uncompiled student).
        decay: per-update decay in (0, 1); the average spans about 1 / (1 − decay) updates.
    """

    def __init__(self, model: nn.Module, decay: float):
        if not 0.0 < decay < 1.0:
            raise ValueError(f"EMA decay must lie in (0, 1), got {decay}")
        self.model, self.decay, self.updates = model, float(decay), 0
        self.param_names = {name for name, _ in model.named_parameters()}
        self.shadow: dict[str, torch.Tensor] = {k: v.detach().clone() for k, v in model.state_dict().items()}

    @torch.no_grad()
    def update(self) -> None:
        """Fold the model's current weights into the average."""
        d = min(self.decay, (1.0 + self.updates) / (10.0 + self.updates))
        for k, v in self.model.state_dict().items():
            if k in self.param_names and v.is_floating_point():
                self.shadow[k].mul_(d).add_(v.detach(), alpha=1.0 - d)
            else:
                self.shadow[k] = v.detach().clone()
        self.updates += 1

    def state_dict(self) -> dict[str, torch.Tensor]:
        """The averaged weights, in the model's own ``state_dict`` layout."""
        return {k: v.clone() for k, v in self.shadow.items()}

    def load(self, shadow: dict[str, torch.Tensor], updates: int) -> None:
        self.shadow = {k: v.detach().clone().to(self.shadow[k].device) for k, v in shadow.items()}
        self.updates = int(updates)


def attach_weight_average(alg: Any, decay: float) -> WeightAverage:
    """Make rsl_rl's ``Distillation`` ``alg`` keep a ``WeightAverage`` of its student: updated
    after every ``update()``, saved by ``save()`` and restored by ``load()`` (a checkpoint
    without one starts the average from the loaded student)."""
    ema = WeightAverage(alg._raw_student, decay)
    update, save, load = alg.update, alg.save, alg.load

    def update_and_average(*args: Any, **kwargs: Any) -> dict[str, float]:
        out = update(*args, **kwargs)
        ema.update()
        return out

    def save_with_average() -> dict:
        return {**save(), EMA_KEY: ema.state_dict(), EMA_COUNT_KEY: ema.updates}

    def load_with_average(loaded: dict, load_cfg: dict | None, strict: bool) -> bool:
        out = load(loaded, load_cfg, strict)
        if EMA_KEY in loaded:
            ema.load(loaded[EMA_KEY], loaded.get(EMA_COUNT_KEY, 0))
        else:
            ema.load(alg._raw_student.state_dict(), 0)
        return out

    alg.update, alg.save, alg.load = update_and_average, save_with_average, load_with_average
    return ema
