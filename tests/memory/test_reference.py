import numpy as np
import torch

from bimanualshift.memory.bank import MemoryBank, MemoryEntry
from bimanualshift.memory.reference import REFERENCE_DIM, episode_key, reference_vector
from bimanualshift.perception.arm_samples import ArmSamples
from bimanualshift.training.residual_data import episode_memory, retrieved_references


def two_arm_samples(episodes: int = 3, keyframes: int = 2) -> tuple[ArmSamples, torch.Tensor, torch.Tensor]:
    """Synthetic samples: episode e's actions sit at x = e, its features point along axis e."""
    rows = [(e, k, arm) for e in range(episodes) for k in range(keyframes) for arm in ("left", "right")]
    n = len(rows)
    pos = np.array([[e, k, 0.1 if arm == "left" else 0.2] for e, k, arm in rows], np.float32)
    # each arm is where its previous keyframe's action put it (at keyframe 0: beside its first target)
    proprio = np.zeros((n, 9), np.float32)
    for i, (e, k, arm) in enumerate(rows):
        proprio[i, :3] = pos[rows.index((e, k - 1, arm))] if k else pos[i] + [0.0, -0.5, 0.0]
        proprio[i, 6:8] = 1.0  # identity quaternion's w, gripper open
    samples = ArmSamples(
        voxels=np.zeros((n, 1)), proprio=proprio, instructions=["lift the ball"] * n, action_pos=pos,
        action_quat=np.tile([0, 0, 0, 1.0], (n, 1)).astype(np.float32), gripper_open=np.ones(n, np.int64),
        ignore_collisions=np.zeros(n, np.int64), episode=np.array([r[0] for r in rows]),
        keyframe=np.array([r[1] for r in rows]), arm=[r[2] for r in rows], other_proprio=np.zeros((n, 8)),
    )
    features = torch.zeros(n, 4)
    for i, (e, _, _) in enumerate(rows):
        features[i, e] = 1.0
        features[i, 3] = 0.5  # what all episodes share
    text = torch.ones(n, 6)
    return samples, features, text


def test_training_demos_never_retrieve_themselves() -> None:
    samples, features, text = two_arm_samples()
    bank = episode_memory(samples, features, text, threshold=0.0, task="lift_ball")
    assert len(bank) == 3 and bank.trajectories[0].shape == (2, 2, 8)
    base = torch.zeros(len(samples), 8)
    own = retrieved_references(samples, features, text, base, bank, own_memory=True)
    assert own.shape == (len(samples), REFERENCE_DIM)
    # Episode 0's reference comes from another episode (x = 1 or 2), never from itself (x = 0).
    assert set(own[samples.episode == 0, 0].tolist()) <= {1.0, 2.0}
    other = retrieved_references(samples, features, text, base, bank, own_memory=False)
    np.testing.assert_allclose(other[:, 0].numpy(), samples.action_pos[:, 0])  # a held-out query finds itself
    # Per arm and keyframe: the right arm's stored z, the keyframe's stored y, confidence in the last slot.
    np.testing.assert_allclose(other[:, 2].numpy(), samples.action_pos[:, 2])
    np.testing.assert_allclose(other[:, 1].numpy(), samples.action_pos[:, 1])
    assert torch.all(other[:, 8] > 0.99)


def test_no_confident_retrieval_gives_a_zero_reference() -> None:
    bank = MemoryBank(12, threshold=0.95)
    bank.add(episode_key(np.ones(4), [np.ones(4), np.ones(4)]), np.ones((2, 2, 8)), MemoryEntry("t", "i", "demo", 0))
    far = episode_key(np.ones(4), [np.array([1.0, -1, 1, -1]), np.array([-1.0, 1, -1, 1])])
    assert bank.search(far) is None
    assert not reference_vector(None, 0, 0, np.zeros(8)).any()
    found = bank.search(episode_key(np.ones(4), [np.ones(4), np.ones(4)]))
    ref = reference_vector(found, 5, 1, np.full(8, 0.25))
    np.testing.assert_allclose(ref[:3], 0.75)  # stored 1.0 minus the prior's 0.25
    assert ref[8] > 0.99


def test_progress_alignment_follows_the_arm_not_the_keyframe_index() -> None:
    """A stored execution: approach, grasp (close), lift, with the other arm holding still twice. The current
    episode's arm is slower (stays put one keyframe) and starts a few millimetres off: its aligned step stays
    with what it has done, where the global index would run ahead."""
    from bimanualshift.memory.reference import ProgressAlignment

    def row(x: float, z: float, gripper: float) -> list[float]:
        return [x, 0.0, z, 0.0, 0.0, 0.0, 1.0, gripper]

    arm0 = [row(0.5, 0.10, 1), row(0.5, 0.02, 1), row(0.5, 0.02, 0), row(0.5, 0.20, 0)]
    arm1 = [row(0.4, 0.3, 1)] * 4  # holds: the same target repeated
    align = ProgressAlignment(np.stack([arm0, arm1], axis=1))
    start = np.array([0.3, 0.0, 0.3])
    # keyframe 0 at the start; 1 has reached the approach; 2 stuck there (a retry); 3 reached the grasp pose; 4
    # closed; the global index would be 0, 1, 2, 3, 4 -- past the stored execution's end
    poses = [(start, 1.0), (np.array([0.503, 0, 0.1]), 1.0), (np.array([0.503, 0, 0.1]), 1.0),
             (np.array([0.5, 0.004, 0.02]), 1.0), (np.array([0.5, 0.004, 0.02]), 0.0)]
    assert [align.step_of(0, p, g) for p, g in poses] == [0, 1, 1, 2, 3]
    # the holding arm replays its repeated targets one per keyframe, never skipping ahead
    assert [align.step_of(1, np.array([0.4, 0.0, 0.3]), 1.0) for _ in range(5)] == [0, 1, 2, 3, 3]


def test_the_reference_gives_a_rollouts_quaternion_on_the_demos_side() -> None:
    """A rollout stores its executed quaternion with w >= 0, which near the gripper-down pose (the demos' x = +1
    side) may come out negated: the reference gives the same rotation on the demos' side."""
    bank = MemoryBank(12, threshold=0.5)
    stored = np.zeros((1, 2, 8))
    stored[0, :, 3:7] = [-0.999, -0.01, 0.0, 0.04]  # the gripper-down pose, negated by w >= 0
    stored[0, :, 7] = 1.0
    key = episode_key(np.ones(4), [np.ones(4), np.ones(4)])
    bank.add(key, stored, MemoryEntry("t", "i", "refinement", 0))
    ref = reference_vector(bank.search(key), 0, 0, np.zeros(8))
    np.testing.assert_allclose(ref[3:7], [0.999, 0.01, 0.0, -0.04], atol=1e-6)
    assert ref[7] == 1.0
