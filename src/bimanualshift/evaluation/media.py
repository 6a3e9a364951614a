"""Rollout image strips (PNG) and videos (MP4 through imageio's ffmpeg)."""

from __future__ import annotations

from pathlib import Path

import imageio.v3 as iio
import numpy as np

from bimanualshift.utils.io import atomic_writer


def write_strip(path: str | Path, frames: list[np.ndarray]) -> Path:
    path = Path(path)
    with atomic_writer(path) as tmp:
        iio.imwrite(tmp, np.concatenate(frames, axis=1), extension=".png")
    return path


def write_video(path: str | Path, frames: list[np.ndarray], fps: int = 2) -> Path:
    path = Path(path)
    with atomic_writer(path) as tmp:
        iio.imwrite(tmp, np.stack(frames), extension=".mp4", fps=fps, codec="libx264", macro_block_size=1)
    return path
