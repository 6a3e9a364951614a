"""The RVT-2-style prior: its orthographic renderer, the lift from view heat-maps to a 3-D point, the fine stage's
frame, and the prior interface (save/load, frozen weights, clear errors)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from bimanualshift.perception.arm_samples import padded_cloud
from bimanualshift.priors.base import PRIORS, UnimanualPrior, build_prior
from bimanualshift.priors.rvt.modeling_rvt import RVTPrior, gaussian_labels, lift
from bimanualshift.priors.rvt.render import VIEWS, project, render_views

SIZE = 32


def _cube(centre: list[float], half: float) -> tuple[torch.Tensor, torch.Tensor]:
    return torch.tensor([centre]), torch.tensor([half])


def _cloud(points: list[list[float]]) -> torch.Tensor:
    return torch.tensor([points], dtype=torch.float32)


def test_registered_as_a_point_cloud_prior() -> None:
    assert PRIORS["rvt"] is RVTPrior and RVTPrior.observation == "points"
    assert build_prior("rvt", "debug").cloud_points == 256


def test_a_point_lands_in_the_expected_pixel_of_each_view() -> None:
    centre, half = _cube([0.5, 0.0, 0.1], 0.4)
    # Pixels are 2.5 cm: the point sits mid-pixel, 4.5 pixels ahead (+x), 8.5 to the left (+y), 8.5 up (+z); red.
    image = render_views(_cloud([[0.6125, 0.2125, 0.3125, 1.0, 0.0, 0.0]]), centre, half, SIZE)[0]
    expected = {  # (row, col): top view rows grow towards the base, cols towards the right (-y)
        "top": (16 - 5, 16 - 9),
        "front": (16 - 9, 16 - 9),
        "side": (16 - 9, 16 + 4),
    }
    for v, view in enumerate(VIEWS):
        occupied = torch.nonzero(image[v, 4]).tolist()
        assert occupied == [list(expected[view])], view
        assert image[v, :3, expected[view][0], expected[view][1]].tolist() == [1.0, 0.0, 0.0]


def test_zooming_in_keeps_a_point_where_it_is_relative_to_the_cube() -> None:
    point = [0.61, -0.07, 0.05]
    wide = project(torch.tensor([[point]]), *_cube([0.5, 0.0, 0.1], 0.4), SIZE)
    zoomed = project(torch.tensor([[point]]), *_cube(point, 0.05), SIZE)
    assert all(torch.allclose(z, torch.full_like(z, SIZE / 2)) for z in zoomed[:2])  # centred when zoomed on it
    moved = project(torch.tensor([[point]]), *_cube([0.6, -0.07, 0.05], 0.05), SIZE)  # 1 cm behind it in x
    assert moved[0][0, 0, 0] == pytest.approx(SIZE / 2 - 0.01 / 0.05 * SIZE / 2, abs=1e-4)  # top view: 1 cm up
    assert not torch.allclose(wide[0], zoomed[0])


def test_the_nearest_point_wins_each_pixel() -> None:
    centre, half = _cube([0.5, 0.0, 0.1], 0.4)
    high, low = [0.5, 0.0, 0.2, 0.0, 1.0, 0.0], [0.5, 0.0, 0.0, 0.0, 0.0, 1.0]  # green above blue
    for order in ([high, low], [low, high]):
        image = render_views(_cloud(order), centre, half, SIZE)[0]
        top = image[VIEWS.index("top")]
        assert top[:3, SIZE // 2, SIZE // 2].tolist() == [0.0, 1.0, 0.0]  # from above: the higher point


def test_points_outside_the_cube_are_not_drawn() -> None:
    image = render_views(_cloud([[3.0, 0.0, 0.1, 1, 1, 1]]), *_cube([0.5, 0.0, 0.1], 0.4), SIZE)
    assert image.abs().sum() == 0


@pytest.mark.parametrize("centre", [[0.55, 0.0, 0.1], [0.62, -0.1, 0.02]])
def test_lifting_peaked_heatmaps_recovers_the_point_in_that_stage_frame(centre: list[float]) -> None:
    """The fine stage's heat-maps are in its zoomed cube: lifting them gives arm-frame points, not cube offsets."""
    target = torch.tensor([[0.6, -0.08, 0.03]])
    c, h = _cube(centre, 0.08 if centre[0] > 0.6 else 0.4)
    labels = gaussian_labels(target, c, h, SIZE, sigma=0.7)  # a peaked distribution at the target's projection
    heat = torch.log(labels.clamp(min=1e-12)).view(1, len(VIEWS), SIZE, SIZE)
    lifted = lift(heat, c, h, grid=32)
    pixel = float(2 * h[0] / SIZE)
    assert torch.linalg.norm(lifted - target) < pixel


def test_padded_clouds_repeat_points_and_keep_empty_scenes_out_of_view() -> None:
    cloud = np.arange(12, dtype=np.float32).reshape(2, 6)
    padded = padded_cloud(cloud, 5)
    assert padded.shape == (5, 6) and np.array_equal(padded[2], cloud[0]) and np.array_equal(padded[3], cloud[1])
    assert padded_cloud(np.tile(cloud, (4, 1)), 3).shape == (3, 6)
    empty = torch.as_tensor(padded_cloud(np.zeros((0, 6), np.float32), 4))[None]
    assert render_views(empty, *_cube([0.5, 0.0, 0.1], 0.4), SIZE).abs().sum() == 0


def _synthetic(n: int, seed: int) -> tuple[tuple[torch.Tensor, ...], dict[str, torch.Tensor]]:
    """Grey table points and one red cube of points; the target is 2 cm above the red cube's centre."""
    g = torch.Generator().manual_seed(seed)
    table = torch.rand(n, 200, 6, generator=g)
    table[..., 0] = 0.3 + 0.5 * table[..., 0]
    table[..., 1] = -0.3 + 0.6 * table[..., 1]
    table[..., 2] = -0.1
    table[..., 3:] = 0.5
    centre = torch.stack([0.4 + 0.3 * torch.rand(n, generator=g), -0.2 + 0.4 * torch.rand(n, generator=g),
                          torch.full((n,), -0.07)], -1)
    red = centre[:, None] + (torch.rand(n, 56, 3, generator=g) - 0.5) * 0.03
    red = torch.cat([red, torch.tensor([1.0, 0.0, 0.0]).expand(n, 56, 3)], -1)
    cloud = torch.cat([table, red], 1)
    target = centre + torch.tensor([0.0, 0.0, 0.02])
    actions = {"position": target[:, None], "quat": torch.tensor([[[1.0, 0.0, 0.0, 0.0]]]).expand(n, 1, 4),
               "gripper_open": torch.ones(n, 1), "ignore_collisions": torch.ones(n, 1)}
    return (cloud, torch.zeros(n, 9), torch.zeros(n, 384)), actions


def test_the_fine_stage_lowers_the_error_of_the_coarse_one() -> None:
    torch.manual_seed(0)
    model = build_prior("rvt", "debug", {"zoom_half_extent": 0.05, "zoom_noise": 0.02})
    inputs, actions = _synthetic(32, seed=1)
    optimiser = torch.optim.Adam(model.parameters(), lr=3e-3)
    for _ in range(150):
        loss = model.compute_loss(inputs, actions, torch.Generator().manual_seed(0))["total"]
        optimiser.zero_grad()
        loss.backward()
        optimiser.step()
    model.eval()
    with torch.no_grad():
        out = model(*inputs)
    target = actions["position"][:, 0]
    coarse = (out["coarse_position"] - target).norm(dim=-1).median()
    fine = (out["position"] - target).norm(dim=-1).median()
    assert coarse < 0.06  # the coarse stage finds the red cube (its pixels are 2.8 cm)
    assert fine < coarse  # the zoomed stage, in its own frame, refines it


def test_save_load_gives_identical_predictions_and_freezing_keeps_weights(tmp_path: Path) -> None:
    model = build_prior("rvt", "debug").freeze()
    inputs, _ = _synthetic(2, seed=3)
    before = model.predict(*inputs)
    loaded = UnimanualPrior.from_pretrained(model.save_pretrained(tmp_path / "rvt")).freeze()
    after = loaded.predict(*inputs)
    assert torch.equal(before.position, after.position) and torch.equal(before.features, after.features)
    assert before.features.shape == (2, model.feature_dim)
    assert set(before.logits) >= {"translation", "rotation", "gripper", "collision"}
    with pytest.raises(ValueError, match="point clouds"):
        model.observation_input(np.zeros((4, 16, 16, 16), np.float32), None)


def test_loading_overrides_fields_that_keep_the_weights_and_refuses_others(tmp_path: Path) -> None:
    model = build_prior("rvt", "debug").freeze()
    folder = model.save_pretrained(tmp_path / "rvt")
    denser = UnimanualPrior.from_pretrained(folder, {"num_points": 1024}).freeze()
    assert denser.cloud_points == 1024 and model.cloud_points == 256
    inputs, _ = _synthetic(2, seed=3)  # 256 points: the same cloud, the same weights, the same prediction
    assert torch.equal(model.predict(*inputs).position, denser.predict(*inputs).position)
    with pytest.raises(ValueError, match="coarse"):
        UnimanualPrior.from_pretrained(folder, {"dim": 48})  # every tensor of that width is named
