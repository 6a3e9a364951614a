import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from bimanualshift.geometry.cameras import depth_to_world_points, project_world_points
from bimanualshift.geometry.frames import (
    ArmFrame,
    compose_rotation,
    euler_bins_to_quat,
    gripper_angle_deg,
    quat_to_euler_bins,
    rotation_difference,
)
from bimanualshift.geometry.voxels import VoxelGrid


def look_at_extrinsics(pos: np.ndarray, target: np.ndarray) -> np.ndarray:
    z = (target - pos) / np.linalg.norm(target - pos)
    x = np.cross(z, [0, 0, -1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    out = np.eye(4)
    out[:3, :3] = np.stack([x, y, z], axis=1)
    out[:3, 3] = pos
    return out


def test_back_projection_round_trip() -> None:
    k = np.array([[100.0, 0, 32], [0, 100.0, 32], [0, 0, 1]])
    ext = look_at_extrinsics(np.array([1.0, 0.5, 1.5]), np.array([0.0, 0.0, 0.8]))
    rng = np.random.default_rng(0)
    depth = rng.uniform(0.5, 2.0, size=(64, 64)).astype(np.float32)
    world = depth_to_world_points(depth, k, ext)
    uv = project_world_points(world, k, ext)
    cols, rows = np.meshgrid(np.arange(64), np.arange(64))
    np.testing.assert_allclose(uv[..., 0], cols, atol=1e-3)
    np.testing.assert_allclose(uv[..., 1], rows, atol=1e-3)
    # The depth is the distance along the optical axis.
    cam = (world - ext[:3, 3]) @ ext[:3, :3]
    np.testing.assert_allclose(cam[..., 2], depth, rtol=1e-5)


def test_voxelisation_of_known_points() -> None:
    grid = VoxelGrid((0.0, 0.0, 0.0, 1.0, 1.0, 1.0), 4)
    points = np.array([[0.1, 0.1, 0.1], [0.2, 0.2, 0.2], [0.9, 0.6, 0.3], [1.5, 0.5, 0.5]])
    colors = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, 1.0, 0], [1, 1, 1]])
    v = grid.voxelize(points, colors)
    assert v.shape == (4, 4, 4, 4)
    assert v[0].sum() == 2  # two cells: the first two points share one, the last point is outside
    np.testing.assert_allclose(v[1:, 0, 0, 0], [0.5, 0.0, 0.5])  # mean colour of the shared cell
    np.testing.assert_allclose(v[1:, 3, 2, 1], [0.0, 1.0, 0.0])
    np.testing.assert_allclose(grid.index_to_point([3, 2, 1]), [0.875, 0.625, 0.375])


def test_bad_grid_bounds_are_rejected() -> None:
    with pytest.raises(ValueError, match="max > min"):
        VoxelGrid((0, 0, 0, 1, -1, 1), 8)


def test_arm_frame_round_trip_and_yaw() -> None:
    frame = ArmFrame((-0.5, 0.3, 0.9), yaw=np.pi / 2)
    p = np.array([0.1, 0.2, 1.0])
    np.testing.assert_allclose(frame.points_to_world(frame.points_to_arm(p)), p, atol=1e-9)
    # A point one metre along world +y from the base is straight ahead of a base yawed by 90 degrees.
    np.testing.assert_allclose(frame.points_to_arm(np.array([-0.5, 1.3, 0.9])), [1.0, 0.0, 0.0], atol=1e-9)
    q = Rotation.from_euler("xyz", [0.3, -0.2, 0.5]).as_quat()
    pos, quat = frame.pose_to_world(*frame.pose_to_arm(p, q))
    np.testing.assert_allclose(pos, p, atol=1e-9)
    assert Rotation.from_quat(quat).approx_equal(Rotation.from_quat(q), atol=1e-9)


def test_rotation_composition_is_on_so3() -> None:
    base = Rotation.from_euler("xyz", [170, 10, 80], degrees=True).as_quat()
    target = Rotation.from_euler("xyz", [-175, -5, 95], degrees=True).as_quat()
    r = rotation_difference(target, base)
    assert Rotation.from_quat(compose_rotation(base, r)).approx_equal(Rotation.from_quat(target), atol=1e-9)
    # Adding Euler angles would have wrapped around +-180 degrees; the residual is a small rotation.
    assert np.linalg.norm(r) < np.deg2rad(30)


def test_euler_bins_round_trip_within_half_a_bin() -> None:
    q = Rotation.from_euler("xyz", [33, -47, 121], degrees=True).as_quat()
    back = euler_bins_to_quat(quat_to_euler_bins(q, 10.0), 10.0)
    angle = (Rotation.from_quat(back) * Rotation.from_quat(q).inv()).magnitude()
    assert np.rad2deg(angle) < 10.0


def test_slerp_and_rotation_angle_match_scipy() -> None:
    from scipy.spatial.transform import Rotation, Slerp

    from bimanualshift.geometry.frames import rotation_angle, slerp

    rng = np.random.default_rng(3)
    for _ in range(50):
        a, b = Rotation.random(2, random_state=rng)
        reference = Slerp([0.0, 1.0], Rotation.concatenate([a, b]))
        for t in (0.0, 0.3, 1.0):
            ours = Rotation.from_quat(slerp(a.as_quat(), b.as_quat(), t))
            assert (ours * reference(t).inv()).magnitude() < 1e-7
        assert abs(rotation_angle(a.as_quat(), b.as_quat()) - (b * a.inv()).magnitude()) < 1e-7
    q = Rotation.random(random_state=rng).as_quat()
    assert rotation_angle(q, -q) < 1e-7  # q and -q are the same rotation


def test_a_half_turn_about_the_approach_axis_is_the_same_grasp() -> None:
    down = Rotation.from_quat([np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0])  # pointing down: its z is the world's -z
    turned = (Rotation.from_euler("z", np.radians(170)) * down).as_quat()  # a world-vertical turn of 170 degrees
    assert np.isclose(gripper_angle_deg(down.as_quat(), turned), 10.0, atol=1e-6)
    tilted = (Rotation.from_euler("x", np.radians(30)) * down).as_quat()  # a tilt is not forgiven
    assert np.isclose(gripper_angle_deg(down.as_quat(), tilted), 30.0, atol=1e-6)


def test_quat_toward_keeps_near_gripper_down_poses_on_one_side_and_the_rotation_unchanged() -> None:
    import torch

    from bimanualshift.geometry.frames import GRIPPER_DOWN_QUAT, canonical_quat, quat_toward
    from bimanualshift.geometry.torch_rotations import quat_toward as quat_toward_torch

    # two poses a degree apart on either side of the gripper-down pose: w >= 0 gives them opposite signs
    tilt = [Rotation.from_quat(GRIPPER_DOWN_QUAT) * Rotation.from_euler("x", a, degrees=True) for a in (-1, 1)]
    w_positive = canonical_quat(np.stack([r.as_quat() for r in tilt]))
    assert np.sign(w_positive[0, 0]) != np.sign(w_positive[1, 0])
    toward = quat_toward(w_positive)
    assert (toward[:, 0] > 0).all() and np.linalg.norm(toward[0] - toward[1]) < 0.05
    for q, r in zip(toward, tilt):
        assert Rotation.from_quat(q).approx_equal(r, atol=1e-9)
    np.testing.assert_allclose(quat_toward_torch(torch.as_tensor(w_positive)).numpy(), toward)
