"""Every training run a shipped policy (or a run) descends from, oldest first, with each run's
env steps, wall-clock, machines and exact command lines, read from the runs' ``train_meta.json``
(committed for the shipped policies' runs). A model card lists the commands of the last run
only; the weights descend through ``--init-from``, ``--teacher`` and the second teachers and
frozen partners a run names (``--train.distillation.fallback-teacher`` / ``rough-teacher`` /
``rescue-student``, ``--train.episode.upright-policy`` / ``tilted-policy``). Replaying the
commands in this order retrains the policy (a draw of its recipe, not its bits: see
docs/training.md).

    python scripts/lineage.py --policy incline
    python scripts/lineage.py --run runs/incline_env395_stance03

A run whose command says ``--iterations 100000`` was stopped by hand: train it to the checkpoint
its child uses (``uses model_K.pt``: ``--iterations K+1``). A run that went on past the checkpoint its child used (``uses model_K.pt``), or the last run
past the checkpoint that shipped (its card names it), is listed with all its steps, so the total
is an upper bound where that happens.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import tyro

from selfright.policies.registry import shipped_path

META = "train_meta.json"


@dataclass(frozen=True)
class Args:
    policy: str | None = None
    """A shipped policy name (its card's ``--out`` names the last run)."""
    run: Path | None = None
    """A run folder (or a checkpoint in one) instead of ``--policy``."""
    root: Path = Path(".")
    """Where the ``runs/`` paths in the metas are relative to (the repository root)."""


def card_run(name: str) -> Path:
    """The run a shipped policy's card says trained it (the ``--out`` of its command block)."""
    card = shipped_path(name).with_suffix(".md")
    if not card.exists():
        raise SystemExit(f"no shipped policy {name!r} (no {card})")
    block = card.read_text().partition("Trained with")[2].partition("```bash")[2].partition("```")[0]
    outs = re.findall(r"--out (\S+)", block)
    if not outs:
        raise SystemExit(f"{card} names no training run (no --out in its commands)")
    return Path(outs[0])


def sources(meta: dict[str, Any]) -> list[tuple[str, str]]:
    """(relation, path) of every policy a run's weights or labels came from."""
    tc = meta.get("train_config", {})
    dist, ep = tc.get("distillation", {}), tc.get("episode", {})
    named = [
        ("--init-from", meta.get("init_from")),
        ("--teacher", meta.get("teacher")),
        ("fallback teacher", dist.get("fallback_teacher")),
        ("rough teacher", dist.get("rough_teacher")),
        ("rescue student", dist.get("rescue_student")),
        ("upright policy", ep.get("upright_policy")),
        ("tilted policy", ep.get("tilted_policy")),
    ]
    return [(rel, str(p)) for rel, p in named if p]


def run_dir(path: str, root: Path) -> Path | None:
    """The run folder holding ``path`` (a run or one of its checkpoints), if it has a meta."""
    p = root / path
    d = p if p.is_dir() else p.parent
    return d if (d / META).exists() else None


def walk(run: Path, root: Path, seen: dict[Path, dict], order: list[Path], edges: dict[Path, list[str]]) -> None:
    """Depth-first over the sources, appending each run after its own sources."""
    run = run.resolve()
    if run in seen:
        return
    meta = json.loads((run / META).read_text())
    seen[run] = meta
    edges[run] = []
    for rel, src in sources(meta):
        parent = run_dir(src, root)
        used = f" (uses {Path(src).name})" if Path(src).suffix == ".pt" else ""
        if parent is None:
            edges[run].append(f"{rel} {src}{used}: no run meta here (a shipped policy or a file)")
            continue
        edges[run].append(f"{rel} {rel_path(parent, root)}{used}")
        walk(parent, root, seen, order, edges)
    order.append(run)


def rel_path(p: Path, root: Path) -> str:
    try:
        return str(p.resolve().relative_to(root.resolve()))
    except ValueError:
        return str(p)


def main(a: Args) -> None:
    if (a.policy is None) == (a.run is None):
        raise SystemExit("give one of --policy NAME or --run runs/NAME")
    start = card_run(a.policy) if a.policy else a.run
    assert start is not None
    first = run_dir(str(start), a.root)
    if first is None:
        # A run folder renamed after shipping (runs/flat_teacher → runs/flat_teacher_best) keeps
        # the --out it was trained with in its meta's command lines.
        renamed = sorted(m.parent for m in (a.root / "runs").glob(f"*/{META}")
                         if all(f"--out {start} " in c + " " for c in json.loads(m.read_text()).get("command_lines", [""])))
        hint = f"; runs whose commands wrote to {start}: {', '.join(rel_path(r, a.root) for r in renamed)}" if renamed else ""
        raise SystemExit(f"{start}: no {META} there (runs/ holds the committed metas of the shipped runs){hint}")
    seen: dict[Path, dict] = {}
    order: list[Path] = []
    edges: dict[Path, list[str]] = {}
    walk(first, a.root, seen, order, edges)
    steps = hours = 0.0
    for i, run in enumerate(order, 1):
        m = seen[run]
        devices = sorted({d for d in m.get("command_devices", []) if d}) or [m.get("device", "?")]
        print(f"{i}. {rel_path(run, a.root)}: {m.get('role')} / {m.get('context')}, "
              f"{m.get('iterations_done')} iterations, {m.get('env_steps', 0):,} env steps, "
              f"{m.get('wall_clock_s', 0) / 3600:.2f} h on {' | '.join(devices)}")
        for e in edges[run]:
            print(f"   from {e}")
        for cmd in m.get("command_lines", []):
            print("   $ " + re.sub(r"^\S*/(selfright|cli\.py) ", r"selfright ", cmd))
        steps += m.get("env_steps", 0)
        hours += m.get("wall_clock_s", 0) / 3600
    print(f"{len(order)} runs, {steps:,.0f} env steps, {hours:.2f} h of training in all "
          "(runs that went on past the checkpoint used count in full)")


if __name__ == "__main__":
    main(tyro.cli(Args))
