"""A world: one evaluation/training context compiled to a MuJoCo model."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from selfright.config import BenchmarkConfig, ContextConfig
from selfright.robots import RobotSpec, get_robot
from selfright.sim.scene import scene_mjcf, spawn_y_fixed
from selfright.terrain import Cell, Tile, make_tile


@dataclass(frozen=True)
class World:
    """A terrain cell with its tile, physical context and compiled model."""

    cell: Cell
    tile: Tile
    context: ContextConfig
    model: mujoco.MjModel
    xml: str

    @property
    def fixed_spawn_y(self) -> bool:
        return spawn_y_fixed(self.context)


def tile_rng(seed: int, cell: Cell, variant: int = 0) -> np.random.Generator:
    """Generator of a cell's tile: depends only on the seed, the cell and a variant index."""
    key = (cell.slope_level + 1, cell.roughness_level, int(round(cell.slope_pct * 1000)), variant, 0xA11E)
    return np.random.default_rng(np.random.SeedSequence(entropy=seed, spawn_key=key))


def build_world(
    cell: Cell, cfg: BenchmarkConfig, context: ContextConfig, seed: int, variant: int = 0,
    robot: RobotSpec | None = None,
) -> World:
    """Generate the cell's tile (seeded) and compile robot + tile + context into a model."""
    robot = robot or get_robot(cfg.robot.name)
    t = cfg.terrain
    tile = make_tile(
        slope_pct=cell.slope_pct,
        roughness_extent_m=cell.roughness_extent_m,
        size_m=t.tile_size_m,
        resolution_m=t.resolution_m,
        noise_wavelength_m=t.noise_wavelength_m,
        rng=tile_rng(seed, cell, variant),
    )
    xml = scene_mjcf(robot, tile, context, cfg.robot, cfg.sim)
    return World(cell=cell, tile=tile, context=context, model=mujoco.MjModel.from_xml_string(xml), xml=xml)
