import numpy as np
import pytest

from selfright.terrain import heightfield_points, make_tile, roughness


def grid_points(n: int, res: float, z: np.ndarray) -> np.ndarray:
    return heightfield_points(z.reshape(n, n), res)


def test_plane_has_zero_roughness():
    n, res = 11, 0.1
    xs = np.arange(n) * res
    z = 0.3 * xs[None, :] - 0.2 * xs[:, None] + 1.0  # tilted plane
    assert roughness(grid_points(n, res, z), area=1.0) == pytest.approx(0.0, abs=1e-12)


def test_checkerboard_offsets_known_value():
    # ±d about z = 0 in a checkerboard: the PCA plane is z = 0, every distance is d,
    # so R = N·d / A.
    n, res, d = 10, 0.1, 0.02
    z = d * np.where((np.add.outer(np.arange(n), np.arange(n)) % 2) == 0, 1.0, -1.0)
    area = 2.5
    assert roughness(grid_points(n, res, z), area) == pytest.approx(n * n * d / area, rel=1e-9)


def test_checkerboard_on_tilted_plane_measures_perpendicular_distance():
    # The same ±d bumps on a 45° plane lie d·cos45° from the fitted plane.
    n, res, d = 20, 0.05, 0.01
    xs = np.arange(n) * res
    sign = np.where((np.add.outer(np.arange(n), np.arange(n)) % 2) == 0, 1.0, -1.0)
    z = xs[None, :] + d * sign
    expected = n * n * d * np.cos(np.pi / 4) / 1.0
    assert roughness(grid_points(n, res, z), 1.0) == pytest.approx(expected, rel=1e-3)


def test_scales_inversely_with_area():
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.4]], dtype=float)
    assert roughness(pts, 2.0) == pytest.approx(roughness(pts, 1.0) / 2)


@pytest.mark.parametrize("bad", [np.zeros((2, 3)), np.zeros((5, 2)), np.full((4, 3), np.nan)])
def test_rejects_bad_points(bad):
    with pytest.raises(ValueError):
        roughness(bad, 1.0)


def test_rejects_nonpositive_area():
    with pytest.raises(ValueError):
        roughness(np.random.default_rng(0).normal(size=(10, 3)), 0.0)


def test_tile_roughness_grows_with_extent():
    rs = []
    for extent in (0.0, 0.1, 0.3):
        tile = make_tile(slope_pct=30, roughness_extent_m=extent, size_m=4, resolution_m=0.05,
                         noise_wavelength_m=0.25, rng=np.random.default_rng(0))
        rs.append(tile.roughness())
    assert rs[0] == pytest.approx(0.0, abs=1e-9)
    assert rs[0] < rs[1] < rs[2]
