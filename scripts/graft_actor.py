"""Fork a PPO run with another actor: copy ``--run``'s checkpoint (its critic, optimiser state
and action std) into a new run folder with the actor's weights and normaliser taken from
``--actor`` (a distilled student's or another PPO run's checkpoint of the same network), so
that ``selfright train … --resume`` goes on with PPO from that actor and a critic already
trained on nearly the same policy. The shipped `incline` since the thirty-first session is a
student distilled from a PPO run's actor; this puts it back into that run:

    python scripts/graft_actor.py --run runs/incline_student_ppo/model_2256.pt \\
        --actor runs/incline_student_stance/model_252.pt --out runs/incline_sppo_stance
    selfright train --role student-ppo … --out runs/incline_sppo_stance --resume

Adam's moment estimates stay those of the run's own actor (the same shapes; the actors differ
little). The action std is the run's, not the actor's.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import torch
import tyro

from selfright.train.checkpoints import META_FILE


@dataclass(frozen=True)
class Args:
    run: Path
    """The PPO run's checkpoint (``runs/NAME/model_K.pt``); its folder holds ``train_meta.json``."""
    actor: Path
    """The checkpoint whose actor goes in (``student_state_dict`` of a distillation run, or
    ``actor_state_dict`` of a PPO run)."""
    out: Path
    """New run folder (refused if it exists)."""


def main(a: Args) -> None:
    if a.out.exists():
        raise SystemExit(f"graft_actor: {a.out} exists")
    ppo = torch.load(a.run, map_location="cpu", weights_only=False)
    src = torch.load(a.actor, map_location="cpu", weights_only=False)
    actor = src.get("student_state_dict") or src.get("actor_state_dict")
    if actor is None or "actor_state_dict" not in ppo:
        raise SystemExit("graft_actor: --run needs an actor_state_dict (PPO), --actor a student or actor state dict")
    own = ppo["actor_state_dict"]
    if {k: v.shape for k, v in own.items()} != {k: v.shape for k, v in actor.items()}:
        raise SystemExit("graft_actor: the two actors differ in their networks")
    ppo["actor_state_dict"] = {k: (own[k] if k == "distribution.std_param" else actor[k].clone()) for k in own}
    a.out.mkdir(parents=True)
    torch.save(ppo, a.out / a.run.name)
    meta = json.loads((a.run.parent / META_FILE).read_text())
    meta["latest_checkpoint"] = str(a.out / a.run.name)
    meta["grafted_actor"] = str(a.actor)
    (a.out / META_FILE).write_text(json.dumps(meta, indent=2))
    print(f"{a.out / a.run.name}: {a.run}'s critic, optimiser and std, {a.actor}'s actor")


if __name__ == "__main__":
    main(tyro.cli(Args))
