"""The incline × roughness grid: level numbers to physical parameters, and named grids."""

from __future__ import annotations

import math
from dataclasses import dataclass

from selfright.config import TerrainConfig


@dataclass(frozen=True, kw_only=True)
class Cell:
    """One cell of an evaluation grid: a slope and a roughness level."""

    slope_level: int
    """Slope level (0 = flat, each level adds ``TerrainConfig.slope_step_pct`` of grade)."""
    roughness_level: int
    """Roughness level (0 = perfect plane)."""
    slope_pct: float
    """Grade of the tile (%), rise over run × 100."""
    roughness_extent_m: float
    """Peak-to-peak vertical extent of the roughness noise (m)."""

    @property
    def slope_deg(self) -> float:
        return math.degrees(math.atan(self.slope_pct / 100.0))


def slope_pct(level: int, cfg: TerrainConfig) -> float:
    """Grade (%) of a slope level."""
    return level * cfg.slope_step_pct


def roughness_extent(level: int, cfg: TerrainConfig) -> float:
    """Peak-to-peak noise extent (m) of a roughness level: linear in the level, top level = bound."""
    top = cfg.num_roughness_levels - 1
    return cfg.max_roughness_extent_m * level / top


def check_levels(slope_level: int, roughness_level: int, cfg: TerrainConfig) -> None:
    """Raise ``ValueError`` with the valid ranges when a level is out of range."""
    if not 0 <= slope_level < cfg.num_slope_levels:
        raise ValueError(f"slope level {slope_level} out of range 0..{cfg.num_slope_levels - 1}")
    if not 0 <= roughness_level < cfg.num_roughness_levels:
        raise ValueError(
            f"roughness level {roughness_level} out of range 0..{cfg.num_roughness_levels - 1}"
        )


def make_cell(slope_level: int, roughness_level: int, cfg: TerrainConfig) -> Cell:
    """The cell of these levels (``ValueError`` when out of range)."""
    check_levels(slope_level, roughness_level, cfg)
    return Cell(
        slope_level=slope_level,
        roughness_level=roughness_level,
        slope_pct=slope_pct(slope_level, cfg),
        roughness_extent_m=roughness_extent(roughness_level, cfg),
    )


GRIDS = ("tiny", "quick", "paper", "flat", "rough", "incline")
INCLINE_DEG = 20.0
"""Slope of the incline training context and of ``--grid incline`` (deg, seed §V)."""
ROUGH_GRID_LEVELS = (4, 8, 12)
"""Roughness levels of ``--grid rough`` (level ground): 0.105 m, 0.21 m, 0.32 m extents."""


def grid_cells(name: str, cfg: TerrainConfig) -> list[Cell]:
    """Cells of a named grid.

    tiny: slope levels {0, 1} × roughness {0, 1} (for tests); quick: every other level;
    paper: the full grid; flat: the flat plane; rough: level ground at a few roughness
    levels; incline: a 20° smooth slope (robots fall with uniform yaw, so all directions).
    """
    if name == "tiny":
        pairs = [(s, r) for s in (0, 1) for r in (0, 1)]
    elif name == "quick":
        pairs = [(s, r) for s in range(0, cfg.num_slope_levels, 2) for r in range(0, cfg.num_roughness_levels, 2)]
    elif name == "paper":
        pairs = [(s, r) for s in range(cfg.num_slope_levels) for r in range(cfg.num_roughness_levels)]
    elif name == "flat":
        return [make_cell(0, 0, cfg)]
    elif name == "rough":
        return [make_cell(0, r, cfg) for r in ROUGH_GRID_LEVELS if r < cfg.num_roughness_levels]
    elif name == "incline":
        pct = 100.0 * math.tan(math.radians(INCLINE_DEG))
        return [Cell(slope_level=-1, roughness_level=0, slope_pct=pct, roughness_extent_m=0.0)]
    else:
        raise ValueError(f"unknown grid {name!r}; choose one of: {', '.join(GRIDS)}")
    return [make_cell(s, r, cfg) for s, r in pairs]
