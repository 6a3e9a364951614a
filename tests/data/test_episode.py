from pathlib import Path

import h5py
import numpy as np
import pytest

from bimanualshift.data.episode import EpisodeFormatError, episode_is_current, read_episode, write_episode


def test_round_trip(bimanual_episode_path: Path, tmp_path: Path) -> None:
    ep = read_episode(bimanual_episode_path)
    assert ep.task == "push_two_buttons" and ep.success
    assert ep.arm_names == ["left", "right"]
    assert ep["rgb"].shape[1] == len(ep.camera_names) == 6
    assert ep["actions"].shape == (ep.num_keyframes, 2, 9)
    copy = write_episode(tmp_path / "copy.h5", ep)
    again = read_episode(copy)
    for key, value in ep.arrays.items():
        np.testing.assert_array_equal(again[key], value)
    assert again.instruction == ep.instruction and again.seed == ep.seed
    assert again.instance_names == ep.instance_names
    assert again.instance_colours == ep.instance_colours and len(ep.instance_colours) == 3  # three painted caps
    assert ep.dense is not None and again.dense is not None
    for key, value in ep.dense.items():
        np.testing.assert_array_equal(again.dense[key], value)


def test_collected_episode_carries_its_dense_trajectory(bimanual_episode_path: Path) -> None:
    ep = read_episode(bimanual_episode_path)
    dense = ep.dense
    assert dense is not None
    steps = dense["eef_pose"].shape[0]
    assert steps > 4 * ep.num_keyframes  # many control steps per keyframe
    assert dense["joint_positions"].shape == (steps, 2, 7)
    # The proprio stored at keyframe 0 is the pose the dense trajectory starts from.
    np.testing.assert_allclose(dense["eef_pose"][0, :, :3], ep["proprio"][0, :, :3], atol=2e-3)
    # Each gripper's open/close switches happen in the dense record as in the keyframe actions.
    for arm in range(2):
        assert set(np.unique(dense["gripper_open"][:, arm])) <= {0.0, 1.0}
    ep.dense["eef_pose"] = ep.dense["eef_pose"][:, :1]
    with pytest.raises(EpisodeFormatError, match=r"dense\['eef_pose'\] has shape"):
        write_episode(Path("/nonexistent/never.h5"), ep)


def test_truncated_file_gives_clear_error(bimanual_episode_path: Path, tmp_path: Path) -> None:
    data = bimanual_episode_path.read_bytes()
    bad = tmp_path / "truncated.h5"
    bad.write_bytes(data[: len(data) // 3])
    with pytest.raises(EpisodeFormatError, match="truncated or corrupt"):
        read_episode(bad)


def test_missing_field_and_wrong_shape(bimanual_episode_path: Path, tmp_path: Path) -> None:
    ep = read_episode(bimanual_episode_path)
    path = write_episode(tmp_path / "ep.h5", ep)
    with h5py.File(path, "a") as f:
        del f["depth"]
    with pytest.raises(EpisodeFormatError, match="missing fields \\['depth'\\]"):
        read_episode(path)
    ep.arrays["actions"] = ep.arrays["actions"][:, :, :7]
    with pytest.raises(EpisodeFormatError, match="'actions' has shape"):
        write_episode(tmp_path / "bad.h5", ep)
    assert not (tmp_path / "bad.h5").exists()


def test_missing_and_foreign_files(tmp_path: Path) -> None:
    with pytest.raises(EpisodeFormatError, match="no such episode file"):
        read_episode(tmp_path / "nope.h5")
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["x"] = np.zeros(3)
    with pytest.raises(EpisodeFormatError, match="not a bimanualshift-episode file"):
        read_episode(tmp_path / "other.h5")


def test_failed_write_leaves_no_file(bimanual_episode_path: Path, tmp_path: Path) -> None:
    ep = read_episode(bimanual_episode_path)
    ep.arrays["rgb"] = ep.arrays["rgb"].astype(np.float32)  # wrong dtype: refused before writing
    with pytest.raises(EpisodeFormatError, match="dtype"):
        write_episode(tmp_path / "ep.h5", ep)
    assert list(tmp_path.iterdir()) == []


def test_a_file_without_instance_colours_reads_but_is_not_current(bimanual_episode_path: Path, tmp_path: Path) -> None:
    """Demos recorded before colours were stored still load (colours unknown); a cache of them is re-collected."""
    old = write_episode(tmp_path / "old.h5", read_episode(bimanual_episode_path))
    assert episode_is_current(old)
    with h5py.File(old, "a") as f:
        del f.attrs["instance_colours"]
    assert not episode_is_current(old)
    assert read_episode(old).instance_colours == {}
    assert not episode_is_current(tmp_path / "absent.h5")
