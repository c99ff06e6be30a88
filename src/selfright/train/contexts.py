"""The three training contexts of the seed (§V) as lists of compiled worlds.

flat:    the flat plane.
rough:   level ground, ``EpisodeConfig.rough_variants`` tiles whose roughness extents are
         evenly spaced from ``rough_min_extent_m`` (exclusive) up to ``rough_max_extent_m``
         (noise wavelength: ``TerrainConfig``'s, half a body length). Each episode draws one tile.
incline: a 20° smooth slope rising along +x. No yaw variants are needed: the fall
         orientation is uniform on SO(3), so every heading on the slope occurs. With
         ``EpisodeConfig.curriculum`` one tile per slope of ``incline_curriculum_deg``; with
         ``incline_slopes_deg`` one per listed slope, each episode drawing one.

Each context's tiles can also be built between side walls and on softer ground (the seed's
further factors; ``EpisodeConfig.wall_gap_ratios``, ``ground_timeconsts_s``).

Tiles are listed from easy to hard (the curriculum's levels).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from selfright.config import BenchmarkConfig, ContextConfig
from selfright.env.world import World, build_world
from selfright.terrain import Cell
from selfright.terrain.grid import grid_cells
from selfright.train.config import Context, EpisodeConfig

CONTEXTS: tuple[Context, ...] = ("flat", "rough", "incline")


def training_cells(context: str, cfg: BenchmarkConfig, episode: EpisodeConfig | None = None) -> list[Cell]:
    """Terrain cells of a training context (one per tile variant)."""
    episode = episode or EpisodeConfig()
    if context == "flat":
        return grid_cells("flat", cfg.terrain)
    if context == "incline":
        top = grid_cells("incline", cfg.terrain)[0]
        if episode.curriculum:
            slopes = episode.incline_curriculum_deg
        elif episode.incline_slopes_deg:
            slopes = episode.incline_slopes_deg
        else:
            return [top]
        return [replace(top, slope_pct=100.0 * math.tan(math.radians(deg))) for deg in slopes]
    if context == "rough":
        base = grid_cells("flat", cfg.terrain)[0]
        top = cfg.terrain.num_roughness_levels - 1
        low, high = episode.rough_min_extent_m, episode.rough_max_extent_m
        if not 0.0 <= low < high:
            raise ValueError(f"rough extents need 0 <= rough_min_extent_m < rough_max_extent_m, got {low} and {high}")
        extents = low + (high - low) * np.arange(1, episode.rough_variants + 1) / episode.rough_variants
        return [
            replace(
                base,
                roughness_extent_m=float(e),
                # Nearest benchmark level, for bookkeeping only; the extent is what is built.
                roughness_level=int(round(e / cfg.terrain.max_roughness_extent_m * top)),
                context="rough",
            )
            for e in extents
        ]
    raise ValueError(f"unknown training context {context!r}; choose one of: {', '.join(CONTEXTS)}")


def training_bench(cfg: BenchmarkConfig, episode: EpisodeConfig) -> BenchmarkConfig:
    """The benchmark config of the training env: ``cfg`` with the training tile size."""
    if episode.tile_size_m is None or episode.tile_size_m == cfg.terrain.tile_size_m:
        return cfg
    if episode.tile_size_m < cfg.terrain.spawn_size_m + 1.0:
        raise ValueError(
            f"training tile of {episode.tile_size_m} m leaves no room around the {cfg.terrain.spawn_size_m} m drop square"
        )
    return replace(cfg, terrain=replace(cfg.terrain, tile_size_m=episode.tile_size_m))


def training_factor_contexts(episode: EpisodeConfig) -> list[ContextConfig]:
    """The physical contexts each training tile is built in: open ground at the benchmark's
    contact stiffness, then each side-wall gap of ``wall_gap_ratios``, all of them again at each
    softer ground of ``ground_timeconsts_s`` (the seed's further factors; ``sim.scene`` refuses
    values it cannot build)."""
    gaps, tcs = episode.wall_gap_ratios, episode.ground_timeconsts_s
    if (gaps or tcs) and episode.curriculum:
        raise ValueError("--train.episode.curriculum orders the context's tiles from easy to hard; "
                         "it cannot be combined with --train.episode.wall-gap-ratios / ground-timeconsts-s")
    base = ContextConfig()
    walls = [base] + [replace(base, wall_gap_ratio=float(g)) for g in gaps]
    return walls + [replace(c, ground_timeconst_s=float(t)) for t in tcs for c in walls]


def make_training_worlds(
    context: str, cfg: BenchmarkConfig, seed: int, episode: EpisodeConfig | None = None
) -> list[World]:
    """Compiled worlds of a training context; tiles depend only on ``seed`` and the variant.

    Friction is the nominal 1.0 here; domain randomisation overrides it per episode. With
    ``EpisodeConfig.wall_gap_ratios`` / ``ground_timeconsts_s`` each tile comes once per
    physical context of ``training_factor_contexts`` (the same tile in each).
    """
    episode = episode or EpisodeConfig()
    cells = training_cells(context, cfg, episode)
    return [
        build_world(cell, cfg, ctx, seed, variant=i)
        for ctx in training_factor_contexts(episode)
        for i, cell in enumerate(cells)
    ]
