"""The three training contexts of the seed (§V) as lists of compiled worlds.

flat:    the flat plane.
rough:   level ground, ``EpisodeConfig.rough_variants`` tiles whose roughness extents are
         evenly spaced from the flat plane (exclusive) up to ``rough_max_extent_m`` (noise
         wavelength: ``TerrainConfig``'s, half a body length). Each episode draws one tile.
incline: a 20° smooth slope rising along +x. No yaw variants are needed: the fall
         orientation is uniform on SO(3), so every heading on the slope occurs. With
         ``EpisodeConfig.curriculum`` one tile per slope of ``incline_curriculum_deg``.

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
        if not episode.curriculum:
            return [top]
        return [replace(top, slope_pct=100.0 * math.tan(math.radians(deg))) for deg in episode.incline_curriculum_deg]
    if context == "rough":
        base = grid_cells("flat", cfg.terrain)[0]
        top = cfg.terrain.num_roughness_levels - 1
        low, high = 0.0, episode.rough_max_extent_m
        extents = low + (high - low) * np.arange(1, episode.rough_variants + 1) / episode.rough_variants
        return [
            replace(
                base,
                roughness_extent_m=float(e),
                # Nearest benchmark level, for bookkeeping only; the extent is what is built.
                roughness_level=int(round(e / cfg.terrain.max_roughness_extent_m * top)),
            )
            for e in extents
        ]
    raise ValueError(f"unknown training context {context!r}; choose one of: {', '.join(CONTEXTS)}")


def make_training_worlds(
    context: str, cfg: BenchmarkConfig, seed: int, episode: EpisodeConfig | None = None
) -> list[World]:
    """Compiled worlds of a training context; tiles depend only on ``seed`` and the variant.

    Friction is the nominal 1.0 here; domain randomisation overrides it per episode.
    """
    cells = training_cells(context, cfg, episode or EpisodeConfig())
    return [build_world(cell, cfg, ContextConfig(), seed, variant=i) for i, cell in enumerate(cells)]
