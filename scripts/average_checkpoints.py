"""Average the actor weights of several rsl_rl checkpoints: neighbouring checkpoints of one run
(a cheap test for a flatter, more robust policy), or a *model soup* (Wortsman et al., 2022) of
runs fine-tuned from one shared checkpoint with different seeds.

Each checkpoint contributes its deployed actor: a distilled student's weight average
(``student_ema_state_dict``) when the run kept one, else its student, else its PPO actor. The
output is the middle checkpoint (the last, for an even count) with that actor's MLP weights
replaced by the mean over all inputs; its critic, teacher and optimiser are kept, and its run's
action mapping, motor model and history are written into the output (``infos``), so it runs as
trained wherever it is saved.

Observation normalisers: checkpoints of one run share theirs closely, and by default the middle
checkpoint's is kept. Runs fine-tuned apart each moved their own normaliser, so the same weights
read differently scaled inputs; ``--fold-normaliser`` first folds each checkpoint's normaliser
into its first layer (exact: W (x − m) / (s + eps) + b = (W / (s + eps)) x + (b − W m / (s + eps))),
averages the folded weights, and writes an identity normaliser. Evaluate the result like any
checkpoint:

    python scripts/average_checkpoints.py --out /tmp/flat_avg.pt \
        --checkpoints runs/flat_teacher/model_3269.pt runs/flat_teacher/model_3445.pt runs/flat_teacher/model_3710.pt
    python scripts/average_checkpoints.py --fold-normaliser --out /tmp/soup.pt \
        --checkpoints runs/A/model_399.pt runs/B/model_399.pt
    selfright evaluate --policy /tmp/soup.pt --grid flat --episodes 64 --seed 1
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import torch
import tyro

from selfright.policies.actor import RSL_RL_NORMALIZER_EPS, deployed_actor_key
from selfright.train.checkpoints import policy_hint


@dataclass(frozen=True)
class Args:
    out: Path
    """Where to write the averaged checkpoint (.pt)."""
    checkpoints: tuple[Path, ...]
    """Checkpoints with the same network shapes, e.g. runs/NAME/model_K.pt."""
    fold_normaliser: bool = False
    """Fold each checkpoint's observation normaliser into its first layer before averaging
    (for runs that trained apart); the output's normaliser is the identity."""


def fold(sd: dict[str, torch.Tensor], eps: float = RSL_RL_NORMALIZER_EPS) -> dict[str, torch.Tensor]:
    """``sd`` with its normaliser folded into ``mlp.0`` and replaced by the identity."""
    if any(k.startswith(("rnn.", "estimator.")) for k in sd):
        raise SystemExit("--fold-normaliser handles plain MLP actors only (this one has a GRU or an estimator)")
    out = dict(sd)
    if "obs_normalizer._mean" not in sd:
        return out
    mean, scale = sd["obs_normalizer._mean"].reshape(-1), sd["obs_normalizer._std"].reshape(-1) + eps
    w = sd["mlp.0.weight"] / scale
    out["mlp.0.weight"], out["mlp.0.bias"] = w, sd["mlp.0.bias"] - w @ mean
    out["obs_normalizer._mean"] = torch.zeros_like(sd["obs_normalizer._mean"])
    out["obs_normalizer._std"] = torch.full_like(sd["obs_normalizer._std"], 1.0 - eps)  # std + eps = 1
    out["obs_normalizer._var"] = out["obs_normalizer._std"] ** 2
    return out


def average(paths: tuple[Path, ...], fold_normaliser: bool = False) -> dict:
    """The averaged checkpoint (see the module docstring)."""
    if len(paths) < 2:
        raise SystemExit("give at least two --checkpoints")
    ckpts = [torch.load(p, weights_only=True, map_location="cpu") for p in paths]
    try:
        keys = {deployed_actor_key(c) for c in ckpts}
    except ValueError as e:
        raise SystemExit(str(e)) from None
    if len(keys) > 1:
        raise SystemExit(f"the checkpoints keep their actors under different keys: {sorted(keys)}")
    key = keys.pop()
    actors = [fold(c[key]) if fold_normaliser else c[key] for c in ckpts]
    middle = len(ckpts) // 2 if len(ckpts) % 2 else len(ckpts) - 1
    base, actor = ckpts[middle], dict(actors[middle])
    for name in actor:
        if name.startswith("mlp."):
            shapes = {tuple(a[name].shape) for a in actors}
            if len(shapes) > 1:
                raise SystemExit(f"{name} differs in shape between the checkpoints: {sorted(shapes)}")
            actor[name] = torch.stack([a[name] for a in actors]).mean(dim=0)
    # The middle checkpoint's run metadata (action mapping, motor, history) travels inside the
    # output, which usually lies outside any run folder.
    hint = {**policy_hint(paths[middle], base.get("infos")), "source": "average of " + ", ".join(map(str, paths))}
    return {**base, key: actor, "infos": hint}


def main(a: Args) -> None:
    torch.save(average(a.checkpoints, a.fold_normaliser), a.out)
    how = " (normalisers folded in)" if a.fold_normaliser else ""
    print(f"wrote {a.out}: actor weights averaged over {len(a.checkpoints)} checkpoints{how}")


if __name__ == "__main__":
    main(tyro.cli(Args))
