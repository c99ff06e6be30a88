"""Average the actor weights of several rsl_rl checkpoints of one run (weight averaging of
neighbouring checkpoints, a cheap test for a flatter, more robust policy).

The output is the middle checkpoint (the last, for an even count) with its actor's MLP
weights replaced by the mean over all inputs; its observation normaliser, critic and
optimiser are kept. Evaluate it like any checkpoint:

    python scripts/average_checkpoints.py --out /tmp/flat_avg.pt \
        --checkpoints runs/flat_teacher/model_3269.pt runs/flat_teacher/model_3445.pt runs/flat_teacher/model_3710.pt
    selfright evaluate --policy /tmp/flat_avg.pt --grid flat --episodes 64 --seed 1
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import torch
import tyro


@dataclass(frozen=True)
class Args:
    out: Path
    """Where to write the averaged checkpoint (.pt)."""
    checkpoints: tuple[Path, ...]
    """Checkpoints of one run (same network shapes), e.g. runs/NAME/model_K.pt."""


def average(paths: tuple[Path, ...]) -> dict:
    """The averaged checkpoint (see the module docstring)."""
    if len(paths) < 2:
        raise SystemExit("give at least two --checkpoints")
    ckpts = [torch.load(p, weights_only=True, map_location="cpu") for p in paths]
    base = ckpts[len(ckpts) // 2] if len(ckpts) % 2 else ckpts[-1]
    actor = dict(base["actor_state_dict"])
    for key in actor:
        if key.startswith("mlp."):
            actor[key] = torch.stack([c["actor_state_dict"][key] for c in ckpts]).mean(dim=0)
    return {**base, "actor_state_dict": actor}


def main(a: Args) -> None:
    torch.save(average(a.checkpoints), a.out)
    print(f"wrote {a.out}: actor weights averaged over {len(a.checkpoints)} checkpoints")


if __name__ == "__main__":
    main(tyro.cli(Args))
