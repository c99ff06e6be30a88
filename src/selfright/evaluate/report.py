"""The seed's experiments as one resumable run: each policy on a grid (``selfright evaluate``)
plus its yaw study (``selfright yaw-study``), and a manifest, ``report.json``, from which
``selfright.plots.report_page`` writes the report. Nothing here draws."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from selfright.config import BENCHMARK_VERSION, BenchmarkConfig
from selfright.evaluate.results import write_json
from selfright.evaluate.runner import Executor, evaluate_grid, prepare_out_dir
from selfright.evaluate.yaw import SEED_SLOPES_DEG, run_yaw_study
from selfright.policies.registry import make_policy
from selfright.terrain.grid import INCLINE_DEG

SEED_POLICIES = ("open-loop", "flat", "rough", "incline", "sr")
"""The seed's policy set: the open-loop baseline, the three specialised students and π_SR."""
REPORT_GRIDS = ("tiny", "quick", "paper")
"""Grids a report runs on (``tiny`` for tests)."""


@dataclass(frozen=True, kw_only=True)
class ContextBox:
    """A training context as a region of the grid, drawn as a box on the report's heatmaps."""

    context: str
    """flat | rough | incline."""
    slope_deg: float
    """The context's slope (deg); the box sits on the grid row of the nearest slope."""
    extent_low_m: float
    """Smallest roughness extent (peak to peak, m) of the context's tiles."""
    extent_high_m: float
    """Largest roughness extent (m) of the context's tiles."""


def context_boxes(rough_max_extent_m: float) -> list[ContextBox]:
    """The seed's three training contexts (§V): the flat plane, level ground of roughness
    extents up to ``rough_max_extent_m`` (the rough context's ``EpisodeConfig.rough_max_extent_m``)
    and the smooth 20° incline."""
    return [
        ContextBox(context="flat", slope_deg=0.0, extent_low_m=0.0, extent_high_m=0.0),
        ContextBox(context="rough", slope_deg=0.0, extent_low_m=1e-9, extent_high_m=rough_max_extent_m),
        ContextBox(context="incline", slope_deg=INCLINE_DEG, extent_low_m=0.0, extent_high_m=0.0),
    ]


def run_report(
    policies: list[tuple[str, str]], *, grid: str, episodes: int, seed: int, out_dir: Path, cfg: BenchmarkConfig,
    boxes: list[ContextBox], slopes_deg: tuple[float, ...] = SEED_SLOPES_DEG, progress: bool = True,
    fall_cache: bool = True, executor: Executor = "local", ray_address: str | None = None,
) -> dict[str, Any]:
    """Evaluate each ``(policy, folder name)`` on ``grid`` into ``out_dir/FOLDER`` and run its yaw
    study into ``out_dir/FOLDER/yaw`` (both resume), then write ``out_dir/report.json``, the
    manifest the page is written from; returns it. ``fall_cache``, ``executor`` and
    ``ray_address`` are ``evaluate_grid``'s."""
    if grid not in REPORT_GRIDS:
        raise ValueError(f"--grid must be one of {', '.join(REPORT_GRIDS)}, got {grid!r}")
    if not policies:
        raise ValueError("--policies is empty; name at least one policy")
    folders = [f for _, f in policies]
    if len(set(folders)) != len(folders):
        raise ValueError(f"two policies would share a results folder: {', '.join(folders)}; name each policy once")
    out_dir = Path(out_dir)
    prepare_out_dir(out_dir)
    made = [(name, folder, make_policy(name, cfg)) for name, folder in policies]  # unknown names fail before any run
    run = {"progress": progress, "fall_cache": fall_cache, "executor": executor, "ray_address": ray_address}
    for name, folder, policy in made:
        evaluate_grid(policy, policy_name=name, grid=grid, episodes=episodes, seed=seed, out_dir=out_dir / folder,
                      cfg=cfg, **run)
        run_yaw_study(policy, policy_name=name, slopes_deg=slopes_deg, episodes=episodes, seed=seed,
                      out_dir=out_dir / folder / "yaw", cfg=cfg, **run)
    manifest = {
        "benchmark_version": BENCHMARK_VERSION, "grid": grid, "episodes": episodes, "seed": seed,
        "slopes_deg": [float(d) for d in slopes_deg],
        "policies": [{"name": name, "folder": folder} for name, folder in policies],
        "context_boxes": [vars(b) for b in boxes],
    }
    write_json(out_dir / "report.json", manifest)
    return manifest

