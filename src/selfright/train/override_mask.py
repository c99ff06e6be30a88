"""PPO that learns only from the steps where the trained policy acted.

Inside a composite (``selfright.train.upright_override``) a frozen stand-up policy replaces
the trained policy's action in every upright step, about 80 % of the steps of an escape
specialist's training. rsl_rl's PPO still stores the specialist's own sampled action there and
puts it in the policy gradient with that step's advantage, although the action changed
nothing: those samples are pure noise in the gradient, and they dilute the real ones five-fold
against the entropy bonus, which is the same for every sample. Trained that way the
specialists' action std grew from 0.5 to 1.3 (docs/training.md, *specialists trained inside
their composite*).

``attach_override_mask`` records which slots were overridden at every stored step and, once
the rollout's returns are computed, rewrites the advantages:

* normalised over the steps the policy acted in only (rsl_rl normalises over all of them);
* zero in the overridden steps, so they add nothing to the surrogate;
* divided by the share of kept steps, so the surrogate, a mean over the whole minibatch,
  weighs each kept step as an unmasked rollout of the same size would.

The critic is untouched: it still learns the composite's state values from every step, and a
kept step's GAE advantage still sums the rewards earned while the frozen policy acted after it
(the specialist is credited with what the hand-over it made led to).
"""

from __future__ import annotations

from typing import Any

import torch

from selfright.train.upright_override import UprightOverride


class OverrideMask:
    """Per-step record of the overridden slots of one rollout, and the advantage rewrite.

    Args:
        steps: transitions per env per rollout (the storage's ``num_transitions_per_env``).
        num_envs: env slots.
    """

    def __init__(self, steps: int, num_envs: int):
        self.overridden = torch.zeros(steps, num_envs, dtype=torch.bool)
        self.kept_share = 1.0
        """Share of the latest rollout's steps in which the trained policy acted."""

    def record(self, step: int, overridden: torch.Tensor) -> None:
        """Slots overridden at rollout step ``step`` ((n,) bool)."""
        self.overridden[step] = overridden.to(self.overridden.device)

    @torch.no_grad()
    def rewrite(self, advantages: torch.Tensor, normalize: bool) -> torch.Tensor:
        """``advantages`` (T, n, 1) raw (returns − values) → masked, normalised over the kept
        steps when ``normalize``, and scaled by 1 / kept share (a new tensor)."""
        keep = ~self.overridden.to(advantages.device).unsqueeze(-1)
        n_keep = int(keep.sum())
        self.kept_share = n_keep / keep.numel()
        if n_keep == 0:
            return torch.zeros_like(advantages)
        a = advantages
        if normalize:
            kept = advantages[keep]
            std = kept.std() if n_keep > 1 else torch.zeros((), device=a.device)
            a = (advantages - kept.mean()) / (std + 1e-8)
        return torch.where(keep, a, torch.zeros_like(a)) / self.kept_share


def attach_override_mask(alg: Any, override: UprightOverride) -> OverrideMask:
    """Make rsl_rl's ``PPO`` ``alg`` drop the steps ``override`` took over from its policy
    gradient (module docstring). ``alg`` must normalise advantages over the whole rollout
    (rsl_rl's default), since per-minibatch normalisation would undo the masking."""
    if alg.normalize_advantage_per_mini_batch:
        raise ValueError("masking overridden steps needs advantages normalised over the rollout, not per minibatch")
    st = alg.storage
    mask = OverrideMask(st.num_transitions_per_env, st.num_envs)
    process_env_step, compute_returns = alg.process_env_step, alg.compute_returns

    def process_and_record(obs: Any, rewards: torch.Tensor, dones: torch.Tensor, extras: dict) -> None:
        mask.record(st.step, override.overridden)
        process_env_step(obs, rewards, dones, extras)

    def compute_masked_returns(obs: Any) -> None:
        compute_returns(obs)
        st.advantages = mask.rewrite(st.returns - st.values, normalize=True)

    alg.process_env_step, alg.compute_returns = process_and_record, compute_masked_returns
    return mask
