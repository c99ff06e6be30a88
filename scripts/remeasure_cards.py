"""Re-measure shipped policies' model cards: rewrite each card's success line from a new
evaluation of the shipped policy (same weights), keeping the line it replaces below it as
"Before WHY". For when the benchmark's physics changes, or to state a card's number on this
machine (rows differ across CPU generations; docs/benchmark.md, *Seeds and determinism*).

    for p in flat rough incline; do
      selfright evaluate --policy $p --grid $p --episodes 64 --seed 0 --out remeasure/$p
    done
    python scripts/remeasure_cards.py --evaluations remeasure --why "the stiffer joint stops"

Every ``--evaluations``/NAME/summary.json whose policy is a shipped NAME rewrites NAME.md.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import tyro

from selfright.policies.registry import CHECKPOINT_DIR
from selfright.train.ship import remeasured_card


@dataclass(frozen=True)
class Args:
    evaluations: Path
    """Folder of evaluation folders, one per shipped policy, named as the policy."""
    why: str
    """What changed since the card's number, as in "Before <why>"."""
    dest: Path = CHECKPOINT_DIR
    """Where the shipped policies and their cards live."""


def main(a: Args) -> None:
    done = []
    for summary_path in sorted(a.evaluations.glob("*/summary.json")):
        name = summary_path.parent.name
        card = a.dest / f"{name}.md"
        if not card.exists():
            raise SystemExit(f"{summary_path}: no shipped policy {name!r} in {a.dest}")
        summary = json.loads(summary_path.read_text())
        card.write_text(remeasured_card(card.read_text(), name, summary, a.why))
        done.append(f"{name} {100 * summary['overall']['success_rate']:.1f} %")
    if not done:
        raise SystemExit(f"no */summary.json under {a.evaluations}")
    print("re-measured: " + ", ".join(done))


if __name__ == "__main__":
    main(tyro.cli(Args))
