"""Run folders on disk: ``model_<it>.pt`` checkpoints and ``train_meta.json``.

Kept free of rsl_rl so that evaluation can resolve a run folder to its latest checkpoint
without importing the training stack.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any


META_FILE = "train_meta.json"
CHECKPOINT_RE = re.compile(r"model_(\d+)\.pt")


def list_checkpoints(run_dir: Path) -> list[tuple[int, Path]]:
    """(iteration, path) of the ``model_<it>.pt`` files in ``run_dir``, ascending."""
    if not run_dir.is_dir():
        return []
    found = [(int(m.group(1)), p) for p in run_dir.iterdir() if (m := CHECKPOINT_RE.fullmatch(p.name))]
    return sorted(found)


def latest_checkpoint(path: Path) -> Path:
    """``path`` if it is a checkpoint file, else the newest ``model_<it>.pt`` in the folder."""
    if path.is_file():
        return path
    ckpts = list_checkpoints(path)
    if not ckpts:
        raise ValueError(f"no checkpoint (model_<it>.pt) in {path}; train there first or pass a checkpoint file")
    return ckpts[-1][1]


def read_meta(run_dir: Path) -> dict[str, Any]:
    """The run's ``train_meta.json`` as a dict (empty if missing or unreadable)."""
    try:
        return json.loads((run_dir / META_FILE).read_text())
    except (OSError, ValueError):
        return {}


def policy_hint(ckpt: Path, infos: dict[str, Any] | None) -> dict[str, Any]:
    """What an actor loaded from checkpoint ``ckpt`` should record besides its weights: the
    checkpoint's ``infos`` (else the run's ``policy`` entry), completed with the action mapping
    of the run's ``benchmark_config`` for checkpoints written before it was recorded, the motor
    model it trained with, and the source path."""
    meta = read_meta(ckpt.parent)
    hint = dict(infos or meta.get("policy") or {})
    action = (meta.get("benchmark_config") or {}).get("action") or {}
    if "action_reference" not in hint and "reference" in action:
        hint["action_reference"] = action["reference"]
        hint["action_scale_rad"] = action.get("scale_rad", 0.0)
    robot = (meta.get("benchmark_config") or {}).get("robot") or {}
    if "motor" not in hint and robot:
        hint["motor"] = robot.get("motor", "ideal")
        hint["motor_speed_rad_s"] = robot.get("motor_speed_rad_s") or 0.0
    hint.setdefault("source", str(ckpt))
    return hint

