"""The seed's roughness metric (Eq. 1–2)."""

from __future__ import annotations

import numpy as np


def roughness(points: np.ndarray, area: float) -> float:
    """Roughness R of a terrain tile, seed Eq. 1–2.

    R = (1/A) Σ_i ‖p_i − p̂_i‖, where p̂_i is the projection of p_i onto the plane spanned by
    the first two principal components of the points (their PCA best-fit plane, through the
    centroid). For equally spaced points this is the mean point-to-plane distance divided by
    the area A/N each point occupies.

    Args:
        points: (N, 3) array of (x, y, z) samples of the tile, N ≥ 3.
        area: area A covered by the points (m²), > 0.

    Returns:
        R in 1/m (metres of deviation per square metre).
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or pts.shape[0] < 3:
        raise ValueError(f"points must have shape (N >= 3, 3), got {pts.shape}")
    if not np.isfinite(pts).all():
        raise ValueError("points contain NaN or inf")
    if not area > 0:
        raise ValueError(f"area must be > 0, got {area}")
    centred = pts - pts.mean(axis=0)
    # Right singular vectors = principal axes; the third (least variance) is the plane normal.
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    normal = vt[2]
    distances = np.abs(centred @ normal)
    return float(distances.sum() / area)


def heightfield_points(heights: np.ndarray, resolution_m: float) -> np.ndarray:
    """(rows·cols, 3) points of a heightfield sampled on a regular grid of spacing ``resolution_m``.

    ``heights`` has shape (rows, cols) indexed [y, x]; x and y start at 0.
    """
    rows, cols = heights.shape
    ys, xs = np.meshgrid(np.arange(rows) * resolution_m, np.arange(cols) * resolution_m, indexing="ij")
    return np.stack([xs.ravel(), ys.ravel(), heights.ravel()], axis=1)
