from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from bimanualshift.cli import main
from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.viz.projection_figure import occupied_voxels


def test_occupied_voxels_average_colours_per_voxel() -> None:
    grid = VoxelGrid((0, 0, 0, 1, 1, 1), 2)
    points = np.array([[0.1, 0.1, 0.1], [0.2, 0.2, 0.2], [0.9, 0.9, 0.9], [5.0, 5.0, 5.0]])
    colours = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, 1.0, 0], [1.0, 1.0, 1.0]])
    centres, rgb = occupied_voxels(points, colours, grid)
    np.testing.assert_allclose(centres, [[0.25, 0.25, 0.25], [0.75, 0.75, 0.75]])
    np.testing.assert_allclose(rgb, [[0.5, 0, 0.5], [0, 1.0, 0]])  # the point outside the grid is ignored


def test_viz_projection_writes_a_figure(tmp_path: Path) -> None:
    main(["viz", "projection", "--task", "pick_up_plate", "--image-size", "48", "--keyframe", "1",
          "--out", str(tmp_path)])
    image = iio.imread(tmp_path / "pick_up_plate.png")
    assert image.shape[1] > 2 * image.shape[0]  # three panels side by side
    assert image[..., :3].std() > 10
    with pytest.raises(SystemExit, match="single-arm task"):
        main(["viz", "projection", "--task", "push_button", "--out", str(tmp_path)])
