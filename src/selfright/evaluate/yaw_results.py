"""Result files of a yaw study (``selfright yaw-study``): ``episodes.csv`` (one row per
episode, appended while running, rewritten in canonical order at the end) and ``yaw.csv`` (one
row per slope and direction). Pure file handling; other tools read these files."""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path
from typing import Any

from selfright.evaluate.metrics import wilson_interval

DIRECTIONS = ("down", "up", "cross")
"""Headings of the study, in Table II's column order."""
EPISODE_COLUMNS = (
    "slope_deg", "direction", "episode", "seed", "heading_deg", "success", "hardware_success", "ttr_s", "dtr_m",
    "travel", "travel_deg", "downhill_m", "roll_turns", "energy_j", "diverged",
)
"""Columns of a yaw study's ``episodes.csv``."""
TABLE_COLUMNS = (
    "slope_deg", "direction", "episodes", "successes", "success_rate", "success_ci95_lo", "success_ci95_hi",
    "hardware_successes", "hardware_success_rate", "ttr_mean_s", "dtr_mean_m",
    "travel_down", "travel_up", "travel_cross", "travel_none", "downhill_mean_m", "diverged",
)
"""Columns of ``yaw.csv``: one row per (slope, direction); travel counts are over successes."""
_INT = {"episode", "seed", "success", "hardware_success", "diverged"}


def yaw_table(rows: list[dict[str, Any]], slopes: tuple[float, ...]) -> list[dict[str, Any]]:
    """One aggregate row per (slope, direction) of parsed episode rows (``TABLE_COLUMNS``)."""
    out = []
    for deg in slopes:
        for d in DIRECTIONS:
            here = [r for r in rows if r["slope_deg"] == deg and r["direction"] == d]
            wins = [r for r in here if r["success"]]
            hw = sum(1 for r in here if r["hardware_success"])
            lo, hi = wilson_interval(len(wins), len(here))
            out.append({
                "slope_deg": deg, "direction": d, "episodes": len(here), "successes": len(wins),
                "success_rate": len(wins) / len(here) if here else 0.0, "success_ci95_lo": lo, "success_ci95_hi": hi,
                "hardware_successes": hw, "hardware_success_rate": hw / len(here) if here else 0.0,
                "ttr_mean_s": _mean(r["ttr_s"] for r in wins), "dtr_mean_m": _mean(r["dtr_m"] for r in wins),
                **{f"travel_{t}": sum(1 for r in wins if r["travel"] == t) for t in ("down", "up", "cross", "none")},
                "downhill_mean_m": _mean(r["downhill_m"] for r in wins), "diverged": sum(1 for r in here if r["diverged"]),
            })
    return out


def _mean(values) -> float | None:
    vals = [v for v in values if v is not None]
    return sum(vals) / len(vals) if vals else None


def _format(column: str, v: Any) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if column in _INT or isinstance(v, bool):
        return str(int(v))
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def read_yaw_episodes(path: Path) -> list[dict[str, Any]]:
    """Parsed rows of a yaw study's ``episodes.csv`` (a torn last line is dropped)."""
    if not path.exists():
        return []
    rows = []
    with path.open(newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is not None and tuple(reader.fieldnames) != EPISODE_COLUMNS:
            raise ValueError(f"{path} is not a yaw study's episodes file; use a fresh --out directory")
        for raw in reader:
            try:
                row: dict[str, Any] = {}
                for c in EPISODE_COLUMNS:
                    v = raw[c]
                    row[c] = v if c in ("direction", "travel") else None if v == "" else int(v) if c in _INT else float(v)
                for c in ("success", "hardware_success", "diverged"):
                    row[c] = bool(row[c])
                if row["direction"] not in DIRECTIONS or row["episode"] is None:
                    continue
                rows.append(row)
            except (TypeError, ValueError, KeyError):
                continue  # incomplete trailing line from an interrupted run: it is redone
    return rows


def read_yaw_table(path: Path) -> list[dict[str, Any]]:
    """Rows of a ``yaw.csv`` (numbers as floats/ints, empty cells as None)."""
    with Path(path).open(newline="") as f:
        return [{k: v if k == "direction" else None if v == "" else float(v) for k, v in r.items()} for r in csv.DictReader(f)]


class Appender:
    """Appends finished episode rows to a CSV, flushed to disk at once (a killed run resumes)."""

    def __init__(self, path: Path, existing: list[dict[str, Any]]):
        self.path, self.existing = path, existing

    def __enter__(self) -> Appender:
        self._f = self.path.open("w", newline="")
        self._w = csv.writer(self._f)
        self._w.writerow(EPISODE_COLUMNS)
        self.write(self.existing)
        return self

    def write(self, rows: list[dict[str, Any]]) -> None:
        for r in rows:
            self._w.writerow([_format(c, r[c]) for c in EPISODE_COLUMNS])
        self._f.flush()
        os.fsync(self._f.fileno())

    def __exit__(self, *exc) -> None:
        self._f.close()


def write_csv(path: Path, columns: tuple[str, ...], rows: list[dict[str, Any]]) -> None:
    tmp = path.with_suffix(".csv.tmp")
    with tmp.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for r in rows:
            w.writerow([_format(c, r[c]) for c in columns])
    os.replace(tmp, path)
