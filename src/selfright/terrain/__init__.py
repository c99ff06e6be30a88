"""Terrain: pure-numpy tile generation and the roughness metric. Knows nothing of the simulator."""

from selfright.terrain.grid import GRIDS, Cell, grid_cells, make_cell
from selfright.terrain.heightfield import Tile, make_tile
from selfright.terrain.roughness import heightfield_points, roughness

__all__ = ["GRIDS", "Cell", "Tile", "grid_cells", "heightfield_points", "make_cell", "make_tile", "roughness"]
