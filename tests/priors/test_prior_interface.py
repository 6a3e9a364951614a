from pathlib import Path

import numpy as np
import pytest

from bimanualshift.configs import PRIOR_SIZES, prior_model_config
from bimanualshift.perception.arm_samples import ArmSamples, action_chunks
from bimanualshift.priors.base import build_prior, resolve_prior_path, shipped_priors


def test_shipped_priors_resolve_by_name_and_unknown_names_fail_clearly(tmp_path: Path) -> None:
    for name in shipped_priors():
        assert (resolve_prior_path(name) / "config.json").is_file()
    assert resolve_prior_path(tmp_path) == tmp_path
    with pytest.raises(FileNotFoundError, match="no shipped prior of that name"):
        resolve_prior_path("no_such_prior")
    # the checkpoints shipped before the widened suite also load by their versioned names
    assert resolve_prior_path("peract_suite_v1") == resolve_prior_path("peract_suite")
    assert resolve_prior_path("dp_suite_v1").name == "dp_suite"


def test_an_install_without_the_repositorys_checkpoints_says_where_they_are(tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    from bimanualshift.priors.base import SHIPPED_DIR, SHIPPED_ENV

    monkeypatch.setenv(SHIPPED_ENV, str(tmp_path / "nowhere"))  # as a wheel: no checkpoints/ beside the package
    with pytest.raises(FileNotFoundError, match="this install has no shipped priors.*BIMANUALSHIFT_CHECKPOINTS"):
        resolve_prior_path("peract_suite_v2")
    assert shipped_priors() == []
    monkeypatch.setenv(SHIPPED_ENV, str(SHIPPED_DIR))  # pointed at a clone's checkpoints/
    assert resolve_prior_path("peract_suite_v2") == SHIPPED_DIR / "peract_suite_v2"


def test_named_sizes_reject_unknown_names() -> None:
    assert prior_model_config("peract", "debug")["voxel_size"] == 16
    with pytest.raises(ValueError, match="choose from"):
        prior_model_config("peract", "huge")
    with pytest.raises(ValueError, match="no named sizes"):
        prior_model_config("no_such_type", "default")


def test_action_chunks_follow_each_arm_and_repeat_the_last_keyframe() -> None:
    n = 5  # episode 0: keyframes 0-2 of the right arm; episode 1: keyframes 0-1
    samples = ArmSamples(
        voxels=np.zeros((n, 1)), proprio=np.zeros((n, 9)), instructions=["x"] * n,
        action_pos=np.arange(n * 3, dtype=np.float32).reshape(n, 3), action_quat=np.tile([0, 0, 0, 1.0], (n, 1)),
        gripper_open=np.array([1, 0, 1, 1, 0]), ignore_collisions=np.zeros(n, np.int64),
        episode=np.array([0, 0, 0, 1, 1]), keyframe=np.array([0, 1, 2, 0, 1]), arm=["right"] * n,
        other_proprio=np.zeros((n, 8)),
    )
    chunks = action_chunks(samples, 3)
    assert chunks["position"].shape == (n, 3, 3)
    np.testing.assert_array_equal(chunks["gripper_open"], [[1, 0, 1], [0, 1, 1], [1, 1, 1], [1, 0, 0], [0, 0, 0]])
    np.testing.assert_array_equal(chunks["position"][3, :, 0], [9, 12, 12])  # never crosses into episode 0
    with pytest.raises(ValueError, match="horizon"):
        action_chunks(samples, 0)


@pytest.mark.parametrize("kind", sorted(PRIOR_SIZES))
def test_every_prior_names_its_observation_and_takes_it(kind: str) -> None:
    """``observation`` says what ``predict`` reads; a method of that name would hide it (the DP prior once did)."""
    prior = build_prior(kind, "debug")
    assert prior.observation in ("voxels", "points")
    size = prior.config.voxel_size
    voxels = np.zeros((4, size, size, size), np.float32)
    cloud = np.random.default_rng(0).random((10, 6)).astype(np.float32)
    scene = prior.observation_input(voxels, cloud if prior.observation == "points" else None)
    expected = (prior.cloud_points, 6) if prior.observation == "points" else voxels.shape
    assert scene.shape == expected and (prior.cloud_points > 0) == (prior.observation == "points")
