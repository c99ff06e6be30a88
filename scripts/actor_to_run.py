"""Turn a policy file (a shipped teacher such as ``rough-teacher``, or a ``selfright export``
``.pt``) back into a teacher run folder that ``selfright train --role student --teacher``
accepts: ``model_<it>.pt`` holding the actor in rsl_rl's PPO checkpoint layout, and a
``train_meta.json`` with the network and action mapping (for a shipped policy also its budget
and, when Table I, its reward, read from its model card, so that a student's card can quote
them).

The actor's weights and normaliser are copied exactly, so the run folder evaluates to the same
episodes as the policy file. Useful when a shipped teacher's training run is not on disk:

    python scripts/actor_to_run.py --policy rough-teacher --out runs/rough_teacher_shipped
    selfright train --role student --context rough --teacher runs/rough_teacher_shipped --out runs/NAME
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import torch
import tyro

from selfright.policies.actor import load_actor_file, teacher_checkpoint
from selfright.policies.registry import shipped_path
from selfright.policies.run_files import META_FILE
from selfright.train.ship import card_record


@dataclass(frozen=True)
class Args:
    policy: str
    """A shipped policy name (``rough-teacher``) or a policy file (``.pt`` from ``selfright export``)."""
    out: Path
    """Run folder to write (created; refused if it already holds checkpoints)."""


def _shown(path: Path) -> str:
    """``path`` relative to the working directory where it lies below it (as recorded paths are)."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def main(args: Args) -> None:
    path = Path(args.policy) if Path(args.policy).is_file() else shipped_path(args.policy)
    if not path.is_file():
        raise SystemExit(f"{args.policy}: neither a policy file nor a shipped policy name")
    actor = load_actor_file(path)
    if actor.meta.role == "student":
        raise SystemExit(f"{args.policy} is a student; a distillation teacher reads the teacher observations")
    ckpt = teacher_checkpoint(actor)
    if any(args.out.glob("model_*.pt")):
        raise SystemExit(f"{args.out} already holds checkpoints; choose a new --out")
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out / f"model_{max(int(ckpt['iter']), 0)}.pt"
    torch.save(ckpt, out)
    card = path.with_suffix(".md")
    meta = {
        "role": "teacher",
        "context": actor.meta.context,
        "policy": ckpt["infos"],
        "latest_checkpoint": str(out),
        **(card_record(card.read_text()) if card.is_file() else {}),
        "converted_from": _shown(path),
        "note": "actor weights only (no critic, no optimiser): a distillation teacher, not a PPO run to resume",
    }
    (args.out / META_FILE).write_text(json.dumps(meta, indent=2) + "\n")
    print(f"wrote {out} (from {path}, iteration {actor.meta.iteration})")


if __name__ == "__main__":
    main(tyro.cli(Args))
