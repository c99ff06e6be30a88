"""Result files of a grid evaluation: ``episodes.csv`` (append-only while running, rewritten in
canonical order at the end), ``run.json`` (identity of the run, for safe resumes) and
``summary.json``. Other tools read these files; their columns are a contract."""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path
from typing import Any

COLUMNS = (
    "slope_level", "roughness_level", "slope_pct", "slope_deg", "roughness_R", "friction",
    "episode", "seed", "success", "ttr_s", "dtr_m", "energy_j", "peak_ang_speed", "diverged",
)
INT_COLS = {"slope_level", "roughness_level", "episode", "seed", "success", "diverged"}


class ResultsError(ValueError):
    """A results directory that cannot be used as asked."""


def format_row(row: dict[str, Any]) -> list[str]:
    out = []
    for c in COLUMNS:
        v = row[c]
        if v is None or (isinstance(v, float) and math.isnan(v)):
            out.append("")
        elif c in INT_COLS:
            out.append(str(int(v)))
        elif isinstance(v, float):
            out.append(f"{v:.6g}")
        else:
            out.append(str(v))
    return out


def parse_row(raw: dict[str, str]) -> dict[str, Any]:
    row: dict[str, Any] = {}
    for c in COLUMNS:
        v = raw[c]
        if v == "":
            row[c] = None
        elif c in INT_COLS:
            row[c] = int(v)
        else:
            row[c] = float(v)
    row["success"] = bool(row["success"])
    row["diverged"] = bool(row["diverged"])
    return row


def episode_key(row: dict[str, Any]) -> tuple[int, int, int]:
    return int(row["slope_level"]), int(row["roughness_level"]), int(row["episode"])


def read_episodes(path: Path) -> list[dict[str, Any]]:
    """Rows of an episodes file; a torn last line (killed mid-write) is dropped."""
    if not path.exists():
        return []
    rows = []
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is None:
            return []
        if tuple(reader.fieldnames) != COLUMNS:
            raise ResultsError(f"{path} has unexpected columns; use a fresh --out directory")
        for raw in reader:
            try:
                rows.append(parse_row(raw))
            except (TypeError, ValueError, KeyError):
                continue  # incomplete trailing line from an interrupted run: it is redone
    return rows


class EpisodeWriter:
    """Appends finished episodes to ``episodes.csv`` and flushes them to disk at once."""

    def __init__(self, path: Path, existing: list[dict[str, Any]]):
        self.path = path
        # Rewrite what survived (drops a torn line), then append.
        self._f = path.open("w", newline="")
        self._w = csv.writer(self._f)
        self._w.writerow(COLUMNS)
        for r in existing:
            self._w.writerow(format_row(r))
        self._sync()

    def _sync(self) -> None:
        self._f.flush()
        os.fsync(self._f.fileno())

    def write(self, rows: list[dict[str, Any]]) -> None:
        for r in rows:
            self._w.writerow(format_row(r))
        self._sync()

    def close(self) -> None:
        self._f.close()


def write_canonical(path: Path, rows: list[dict[str, Any]], order: dict[tuple[int, int], int]) -> None:
    """Rewrite the episodes file sorted by grid order then episode (same seed → same bytes)."""
    rows = sorted(rows, key=lambda r: (order[(r["slope_level"], r["roughness_level"])], r["episode"]))
    tmp = path.with_suffix(".csv.tmp")
    with tmp.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow(format_row(r))
    os.replace(tmp, path)


def write_json(path: Path, data: dict[str, Any]) -> None:
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    os.replace(tmp, path)


ADDED_OFF_BY_DEFAULT = {("eval", "sensor_noise"): 0.0}
"""Configuration fields added after results folders were written, whose default is what the code
did before them (off): a recorded configuration without one ran with that value. (Fields whose
default changed behaviour, such as the hard joint stops, are not here: their absence means the
old behaviour, not the new default.)"""


def with_added_defaults(config: dict[str, Any]) -> dict[str, Any]:
    """``config`` (a recorded ``BenchmarkConfig``) with the ``ADDED_OFF_BY_DEFAULT`` fields it lacks."""
    out = {k: dict(v) if isinstance(v, dict) else v for k, v in config.items()}
    for (section, name), value in ADDED_OFF_BY_DEFAULT.items():
        if isinstance(out.get(section), dict):
            out[section].setdefault(name, value)
    return out


def recorded_sensor_noise(summary: dict[str, Any]) -> float:
    """The ``--sensor-noise`` scale a results folder's ``summary.json`` (or ``run.json``) was
    evaluated at; 0 = exact sensors, also for folders written before the option existed."""
    return float((((summary.get("config") or {}).get("eval") or {}).get("sensor_noise")) or 0.0)


def factor_flags(eval_cfg: dict[str, Any]) -> list[tuple[str, str]]:
    """(``selfright evaluate`` flag, words) of each further factor in an ``EvalConfig`` (as a dict:
    a ``summary.json``'s ``config.eval``) set away from the benchmark's default: friction, side
    walls, ground compliance."""
    from selfright.config import EvalConfig

    default, e = EvalConfig(), eval_cfg
    out = []
    if e.get("friction", default.friction) != default.friction:
        out.append((f"--friction {e['friction']:g}", f"friction {e['friction']:g}"))
    if e.get("wall_gap_ratio") is not None:
        out.append((f"--wall-gap-ratio {e['wall_gap_ratio']:g}", f"side walls {e['wall_gap_ratio']:g} body lengths apart"))
    if e.get("ground_timeconst_s", default.ground_timeconst_s) != default.ground_timeconst_s:
        out.append((f"--ground-timeconst {e['ground_timeconst_s']:g}", f"ground time constant {e['ground_timeconst_s']:g} s"))
    return out


def check_run_identity(out: Path, identity: dict[str, Any]) -> None:
    """Refuse to resume into a directory that holds a different run: another benchmark version
    (a ``run.json`` without one is of version 0) or another identity."""
    path = out / "run.json"
    if path.exists():
        try:
            old = json.loads(path.read_text())
        except json.JSONDecodeError as e:
            raise ResultsError(f"{path} is corrupt ({e}); use a fresh --out directory") from e
        version = old.get("benchmark_version", 0)
        if version != identity.get("benchmark_version"):
            raise ResultsError(
                f"{out} holds results of benchmark version {version}; this is version "
                f"{identity.get('benchmark_version')}: use a fresh --out directory"
            )
        if isinstance(old.get("config"), dict):
            old = {**old, "config": with_added_defaults(old["config"])}
        if old != identity:
            diff = sorted(k for k in set(old) | set(identity) if old.get(k) != identity.get(k))
            raise ResultsError(
                f"{out} holds a different run (differs in: {', '.join(diff)}); use a fresh --out directory"
            )
    else:
        write_json(path, identity)
