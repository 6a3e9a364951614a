import numpy as np
import torch
from scipy.spatial.transform import Rotation

from bimanualshift.geometry.voxels import VoxelGrid
from bimanualshift.training.augment import Se3Augmentation, transform_points, transform_quats, transform_voxels
from bimanualshift.training.pretrain import augment_batch

GRID = VoxelGrid((0.2, -0.45, -0.15, 0.9, 0.45, 0.35), 32)


def blobs_at(points: np.ndarray) -> torch.Tensor:
    """One 3x3x3 block of occupied, coloured voxels around each point."""
    voxels = torch.zeros(len(points), 4, 32, 32, 32)
    for b, p in enumerate(points):
        i, j, k = GRID.point_to_index(p)
        voxels[b, :, i - 1:i + 2, j - 1:j + 2, k - 1:k + 2] = torch.tensor([1.0, 0.2, 0.5, 0.9])[:, None, None, None]
    return voxels


def test_voxels_and_targets_move_together() -> None:
    rng = np.random.default_rng(0)
    points = GRID.index_to_point(rng.integers(8, 24, size=(12, 3)))
    yaw, translation = Se3Augmentation(0.05, 30.0).sample(torch.Generator().manual_seed(0), 12)
    assert yaw.abs().max() > np.radians(10) and translation[:, 2].abs().max() == 0  # horizontal motions only
    moved = transform_voxels(blobs_at(points), GRID, yaw, translation)
    targets = transform_points(torch.as_tensor(points, dtype=torch.float32), GRID, yaw, translation)
    for b in range(12):
        i, j, k = GRID.point_to_index(targets[b].numpy())
        assert moved[b, 0, i, j, k] == 1.0  # the target still sits in the object it was on
        centroid = GRID.index_to_point(moved[b, 0].nonzero().float().mean(0).numpy())
        assert np.linalg.norm(centroid - targets[b].numpy()) < 0.75 * GRID.voxel_size.max()
        torch.testing.assert_close(moved[b, 1:, i, j, k], torch.tensor([0.2, 0.5, 0.9]))  # colours kept exactly


def test_orientations_turn_with_the_scene() -> None:
    quats = Rotation.random(5, random_state=1).as_quat()
    yaw = torch.linspace(-0.5, 0.5, 5)
    expected = (Rotation.from_euler("z", yaw.numpy()[:, None]) * Rotation.from_quat(quats)).as_quat()
    got = transform_quats(torch.as_tensor(quats, dtype=torch.float32), yaw).numpy()
    assert Rotation.from_quat(got).approx_equal(Rotation.from_quat(expected), atol=1e-5).all()


def test_batches_whose_target_would_leave_the_grid_stay_unchanged() -> None:
    inside = GRID.index_to_point(np.array([16, 16, 16]))
    edge = GRID.upper - 0.001
    voxels = blobs_at(np.stack([inside, inside]))
    proprio = torch.zeros(2, 9)
    proprio[:, 6] = 1.0  # identity orientation
    actions = {"position": torch.as_tensor(np.stack([inside, edge]), dtype=torch.float32)[:, None],
               "quat": torch.tensor([[[0.0, 0.0, 0.0, 1.0]]] * 2)}
    aug = Se3Augmentation(0.05, 20.0)
    gen = torch.Generator().manual_seed(3)
    new_voxels, new_proprio, new_actions = augment_batch(voxels, proprio, actions, GRID, aug, gen)
    assert torch.equal(new_actions["position"][1], actions["position"][1])  # would have left the grid
    assert torch.equal(new_voxels[1], voxels[1])
    assert not torch.equal(new_actions["position"][0], actions["position"][0])
    assert not torch.equal(new_proprio[0, :3], proprio[0, :3])  # the gripper's pose moves with the scene


def test_goal_geometry_moves_with_the_scene_and_unseen_goals_stay_zero() -> None:
    from bimanualshift.training.augment import transform_goal_geometry

    low, high = np.array([0.5, -0.1, 0.0]), np.array([0.6, 0.1, 0.05])
    seen = torch.as_tensor(np.r_[(low + high) / 2, low, high, 1.0], dtype=torch.float32)
    goal = torch.stack([seen, torch.zeros(10)])
    yaw, shift = torch.tensor([0.3, 0.3]), torch.tensor([[0.02, -0.03, 0.0]] * 2)
    moved = transform_goal_geometry(goal, GRID, yaw, shift)
    torch.testing.assert_close(moved[0, :3], transform_points(seen[None, :3], GRID, yaw[:1], shift[:1])[0])
    # every corner of the moved box lies inside the new bounds, and the bounds touch them
    corners = torch.tensor([[x, y, z] for x in (low[0], high[0]) for y in (low[1], high[1]) for z in (low[2], high[2])],
                           dtype=torch.float32)
    turned = transform_points(corners[None], GRID, yaw[:1], shift[:1])[0]
    torch.testing.assert_close(moved[0, 3:6], turned.min(0).values)
    torch.testing.assert_close(moved[0, 6:9], turned.max(0).values)
    assert moved[0, 9] == 1.0 and torch.equal(moved[1], torch.zeros(10))
    pure_shift = transform_goal_geometry(goal[:1], GRID, torch.zeros(1), shift[:1])  # exact for a translation
    torch.testing.assert_close(pure_shift[0, :9], seen[:9] + shift[0].repeat(3))


def test_goal_extremities_move_with_the_scene() -> None:
    from bimanualshift.training.augment import transform_goal_geometry

    box = [0.55, 0.0, 0.02, 0.5, -0.1, 0.0, 0.6, 0.1, 0.05, 1.0]
    ends = [0.5, -0.1, 0.01, 1.0, 0.0, 0.0, 0.6, 0.1, 0.01, 0.0, -1.0, 0.0]  # tip, direction into the object
    goal = torch.tensor([box + ends, [0.0] * 22])
    yaw, shift = torch.tensor([0.4, 0.4]), torch.tensor([[0.02, -0.03, 0.0]] * 2)
    moved = transform_goal_geometry(goal, GRID, yaw, shift)
    for start in (10, 16):
        torch.testing.assert_close(moved[0, start:start + 3],
                                   transform_points(goal[:1, start:start + 3], GRID, yaw[:1], shift[:1])[0])
        # a direction turns with the yaw and is not shifted: tip + direction maps to moved tip + moved direction
        head = transform_points(goal[:1, start:start + 3] + goal[:1, start + 3:start + 6], GRID, yaw[:1], shift[:1])[0]
        torch.testing.assert_close(moved[0, start + 3:start + 6], head - moved[0, start:start + 3])
    assert torch.equal(moved[1], torch.zeros(22))


def test_each_goal_objects_box_moves_with_the_scene() -> None:
    from bimanualshift.training.augment import transform_goal_geometry

    box = [0.55, 0.0, 0.02, 0.5, -0.1, 0.0, 0.6, 0.1, 0.05, 1.0]
    ends = [0.5, -0.1, 0.01, 1.0, 0.0, 0.0, 0.6, 0.1, 0.01, 0.0, -1.0, 0.0]
    tray = [0.52, 0.05, 0.03, 0.5, 0.03, 0.02, 0.54, 0.07, 0.04, 1.0]
    goal = torch.tensor([box + ends + tray + box + [0.0] * 10])  # third object unseen
    yaw, shift = torch.tensor([0.4]), torch.tensor([[0.02, -0.03, 0.0]])
    moved = transform_goal_geometry(goal, GRID, yaw, shift)
    union = transform_goal_geometry(goal[:, :22], GRID, yaw, shift)
    torch.testing.assert_close(moved[:, :22], union)  # the union part moves as it did before the object boxes
    for start, own in ((22, tray), (32, box)):  # each object's box moves as a union box of its own would
        torch.testing.assert_close(moved[:, start:start + 10],
                                   transform_goal_geometry(torch.tensor([own]), GRID, yaw, shift))
    assert not moved[0, 42:].any()
    assert not torch.equal(moved[0, 22:25], goal[0, 22:25])
