"""Seeded placement of objects on the table."""

from __future__ import annotations

import numpy as np


def sample_separated(rng: np.random.Generator, regions: list[tuple[tuple[float, float], tuple[float, float]]],
                     min_distance: float, max_tries: int = 1000) -> np.ndarray:
    """One xy point per region ((xmin, xmax), (ymin, ymax)), all at least ``min_distance`` apart."""
    for _ in range(max_tries):
        pts = np.array([[rng.uniform(*xr), rng.uniform(*yr)] for xr, yr in regions])
        d = np.linalg.norm(pts[:, None] - pts[None], axis=-1) + np.eye(len(pts)) * 1e9
        if d.min() >= min_distance:
            return pts
    raise RuntimeError(f"could not place {len(regions)} objects {min_distance} m apart in {regions}")
