"""Terrain tiles as heightfields: an inclined plane perturbed by smooth lattice noise.

Pure numpy; every random draw comes from the ``numpy.random.Generator`` passed in.
Heights are stored as ``heights[row, col]`` with row ↔ y and col ↔ x, the tile centred on
the world origin: x = -L/2 + col·res, y = -L/2 + row·res. The incline rises along +x.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from selfright.terrain.roughness import heightfield_points, roughness


@dataclass(frozen=True)
class Tile:
    """One terrain tile."""

    heights: np.ndarray
    """Ground height (m), shape (n, n), indexed [y, x]."""
    resolution_m: float
    """Grid spacing (m)."""
    slope_pct: float
    """Grade of the underlying plane (%), rising along +x."""
    roughness_extent_m: float
    """Peak-to-peak extent of the noise added to the plane (m)."""

    @property
    def size_m(self) -> float:
        return (self.heights.shape[0] - 1) * self.resolution_m

    def height_at(self, xy: np.ndarray) -> np.ndarray:
        """Ground height (m) under points ``xy`` of shape (k, 2), bilinear; clamped at the border."""
        return _bilinear(self.heights, self.resolution_m, xy)

    def max_height_near(self, xy: np.ndarray, radius_m: float) -> np.ndarray:
        """Highest ground (m) within ``radius_m`` (square window) of each point of ``xy`` (k, 2)."""
        n = self.heights.shape[0]
        half = self.size_m / 2
        rad = int(np.ceil(radius_m / self.resolution_m))
        out = np.empty(len(xy))
        for k, (x, y) in enumerate(np.asarray(xy, dtype=np.float64)):
            c = int(round((x + half) / self.resolution_m))
            r = int(round((y + half) / self.resolution_m))
            window = self.heights[max(r - rad, 0) : min(r + rad + 1, n), max(c - rad, 0) : min(c + rad + 1, n)]
            out[k] = window.max()
        return out

    def roughness(self, region_m: float | None = None) -> float:
        """Roughness metric R (1/m) of the tile, or of its central ``region_m`` square."""
        h = self.heights
        if region_m is not None:
            n = h.shape[0]
            k = int(round(region_m / self.resolution_m)) + 1
            lo = (n - k) // 2
            h = h[lo : lo + k, lo : lo + k]
        area = ((h.shape[0] - 1) * self.resolution_m) ** 2
        return roughness(heightfield_points(h, self.resolution_m), area)


def _bilinear(heights: np.ndarray, res: float, xy: np.ndarray) -> np.ndarray:
    return sample_heights(heights[None], np.zeros(len(xy), dtype=np.int64), xy, res)


def sample_heights(stack: np.ndarray, index: np.ndarray, xy: np.ndarray, res: float) -> np.ndarray:
    """Bilinear ground height of tile ``stack[index[k]]`` at point ``xy[k]``, clamped at borders.

    Args:
        stack: (W, n, n) heightfields of tiles centred on the origin, indexed [tile, y, x].
        index: (k,) tile of each point.
        xy: (k, 2) query points (m).
        res: grid spacing (m).

    Returns:
        (k,) heights (m).
    """
    n = stack.shape[1]
    half = (n - 1) * res / 2
    xy = np.asarray(xy, dtype=np.float64)
    gx = np.clip((xy[:, 0] + half) / res, 0.0, n - 1.000001)
    gy = np.clip((xy[:, 1] + half) / res, 0.0, n - 1.000001)
    c0 = np.floor(gx).astype(np.int64)
    r0 = np.floor(gy).astype(np.int64)
    fx = gx - c0
    fy = gy - r0
    h00 = stack[index, r0, c0]
    h01 = stack[index, r0, c0 + 1]
    h10 = stack[index, r0 + 1, c0]
    h11 = stack[index, r0 + 1, c0 + 1]
    return (h00 * (1 - fx) + h01 * fx) * (1 - fy) + (h10 * (1 - fx) + h11 * fx) * fy


def lattice_noise(n: int, res: float, wavelength_m: float, rng: np.random.Generator) -> np.ndarray:
    """Smooth value noise on an (n, n) grid: random lattice values every ``wavelength_m``,
    interpolated with C¹ smoothstep weights, then scaled to span exactly [-0.5, 0.5]."""
    size = (n - 1) * res
    cells = max(int(np.ceil(size / wavelength_m)), 1)
    lattice = rng.uniform(-1.0, 1.0, size=(cells + 1, cells + 1))
    g = np.arange(n) * res / wavelength_m
    i0 = np.minimum(np.floor(g).astype(np.int64), cells - 1)
    t = g - i0
    w = t * t * (3.0 - 2.0 * t)
    r0, c0 = i0[:, None], i0[None, :]
    wy, wx = w[:, None], w[None, :]
    top = lattice[r0, c0] * (1 - wx) + lattice[r0, c0 + 1] * wx
    bottom = lattice[r0 + 1, c0] * (1 - wx) + lattice[r0 + 1, c0 + 1] * wx
    field = top * (1 - wy) + bottom * wy
    span = field.max() - field.min()
    if span <= 0:
        return np.zeros((n, n))
    return (field - field.min()) / span - 0.5


def make_tile(
    *,
    slope_pct: float,
    roughness_extent_m: float,
    size_m: float,
    resolution_m: float,
    noise_wavelength_m: float,
    rng: np.random.Generator,
) -> Tile:
    """An inclined plane (grade ``slope_pct`` along +x) plus noise of peak-to-peak extent
    ``roughness_extent_m`` (exactly; 0 gives a perfect plane)."""
    if roughness_extent_m < 0:
        raise ValueError("roughness extent must be >= 0")
    n = int(round(size_m / resolution_m)) + 1
    x = -size_m / 2 + np.arange(n) * resolution_m
    heights = np.broadcast_to(slope_pct / 100.0 * x[None, :], (n, n)).copy()
    if roughness_extent_m > 0:
        heights += roughness_extent_m * lattice_noise(n, resolution_m, noise_wavelength_m, rng)
    return Tile(heights=heights, resolution_m=resolution_m, slope_pct=slope_pct, roughness_extent_m=roughness_extent_m)
