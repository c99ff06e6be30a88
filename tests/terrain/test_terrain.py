import math

import numpy as np
import pytest

from selfright.config import TerrainConfig
from selfright.terrain import grid_cells, make_cell, make_tile
from selfright.terrain.grid import roughness_extent


def tile(slope=0.0, extent=0.0, seed=0, cfg=TerrainConfig()):
    return make_tile(slope_pct=slope, roughness_extent_m=extent, size_m=cfg.tile_size_m,
                     resolution_m=cfg.resolution_m, noise_wavelength_m=cfg.noise_wavelength_m,
                     rng=np.random.default_rng(seed))


def test_levels_map_to_grade_and_bounded_extent():
    cfg = TerrainConfig()
    assert make_cell(10, 0, cfg).slope_pct == pytest.approx(100.0)
    assert make_cell(10, 0, cfg).slope_deg == pytest.approx(45.0)
    extents = [roughness_extent(r, cfg) for r in range(cfg.num_roughness_levels)]
    assert extents[0] == 0.0
    assert all(b > a for a, b in zip(extents, extents[1:]))
    assert max(extents) <= 0.5 + 1e-12  # never more than one body length


def test_noise_extent_is_exact_and_never_exceeds_body_length():
    t = tile(extent=0.5, seed=3)
    assert np.ptp(t.heights) == pytest.approx(0.5)
    t = tile(slope=40.0, extent=0.2, seed=3)
    x = -t.size_m / 2 + np.arange(t.heights.shape[1]) * t.resolution_m
    residual = t.heights - 0.4 * x[None, :]
    assert np.ptp(residual) == pytest.approx(0.2)


def test_slope_rises_along_x():
    t = tile(slope=50.0)
    h = t.height_at(np.array([[1.0, 0.3], [2.0, -1.0]]))
    assert h == pytest.approx([0.5, 1.0])


def test_same_seed_same_tile_other_seed_other_tile():
    assert np.array_equal(tile(extent=0.2, seed=1).heights, tile(extent=0.2, seed=1).heights)
    assert not np.array_equal(tile(extent=0.2, seed=1).heights, tile(extent=0.2, seed=2).heights)


def test_named_grids():
    cfg = TerrainConfig()
    assert len(grid_cells("tiny", cfg)) == 4
    assert len(grid_cells("quick", cfg)) == 6 * 10
    assert len(grid_cells("paper", cfg)) == 11 * 20
    (inc,) = grid_cells("incline", cfg)
    assert inc.slope_deg == pytest.approx(20.0)
    assert math.isclose(grid_cells("flat", cfg)[0].slope_pct, 0.0)
    with pytest.raises(ValueError, match="unknown grid"):
        grid_cells("huge", cfg)


@pytest.mark.parametrize("s,r", [(-1, 0), (11, 0), (0, 20)])
def test_out_of_range_levels(s, r):
    with pytest.raises(ValueError, match="out of range"):
        make_cell(s, r, TerrainConfig())
