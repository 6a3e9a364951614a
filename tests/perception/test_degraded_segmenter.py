import numpy as np
import pytest

from bimanualshift.perception.segmenters.base import CameraView, Detection
from bimanualshift.perception.segmenters.degraded import LEVELS, Degradation, DegradedSegmenter
from bimanualshift.sim.segmentation import ARM_CLASS


class FixedSegmenter:
    """Two arm candidates and one goal object, as a perfect detector would return them."""

    def segment(self, view: CameraView, prompts: list[str]) -> list[Detection]:
        masks = [np.zeros((32, 32), bool) for _ in range(3)]
        masks[0][4:14, 2:10] = True
        masks[1][4:14, 22:30] = True
        masks[2][20:28, 12:20] = True
        return [Detection(masks[0], ARM_CLASS, 1.0), Detection(masks[1], ARM_CLASS, 1.0),
                Detection(masks[2], "button", 1.0)]


VIEW = CameraView(np.zeros((32, 32, 3), np.uint8))
PROMPTS = [ARM_CLASS, "button"]


def segment(**rates: float) -> list[Detection]:
    return DegradedSegmenter(FixedSegmenter(), Degradation(**rates)).segment(VIEW, PROMPTS)


def test_no_degradation_changes_nothing() -> None:
    clean = FixedSegmenter().segment(VIEW, PROMPTS)
    for a, b in zip(segment(), clean, strict=True):
        assert a.label == b.label and np.array_equal(a.mask, b.mask)


def test_each_error_kind() -> None:
    assert segment(drop=1.0) == []
    merged = [d for d in segment(merge_arms=1.0) if d.label == ARM_CLASS]
    assert len(merged) == 1 and merged[0].mask.sum() == 2 * 80
    areas = [d.mask.sum() for d in DegradedSegmenter(FixedSegmenter(), Degradation(boundary_px=2, seed=3)).segment(
        VIEW, PROMPTS)]
    assert areas != [80, 80, 64]  # boundaries moved
    extra = DegradedSegmenter(FixedSegmenter(), Degradation(false_positives=2.0, seed=0))
    counts = [len(extra.segment(VIEW, PROMPTS)) - 3 for _ in range(200)]
    assert 1.6 < np.mean(counts) < 2.4


def test_noise_is_seeded_and_levels_are_ordered() -> None:
    a = DegradedSegmenter(FixedSegmenter(), LEVELS["strong"]).segment(VIEW, PROMPTS)
    b = DegradedSegmenter(FixedSegmenter(), LEVELS["strong"]).segment(VIEW, PROMPTS)
    assert [d.mask.tolist() for d in a] == [d.mask.tolist() for d in b]
    mild, strong = LEVELS["mild"], LEVELS["strong"]
    assert mild.drop < strong.drop and mild.merge_arms < strong.merge_arms


def test_bad_rates_are_rejected() -> None:
    with pytest.raises(ValueError, match="probability"):
        Degradation(drop=1.5)
    with pytest.raises(ValueError, match=">= 0"):
        Degradation(boundary_px=-1)


def test_segmenters_by_name() -> None:
    from bimanualshift.perception.segmenters import make_segmenter
    from bimanualshift.perception.segmenters.simulator import SimulatorSegmenter

    assert isinstance(make_segmenter("simulator"), SimulatorSegmenter)
    strong = make_segmenter("degraded-strong", seed=4)
    assert isinstance(strong, DegradedSegmenter) and strong.degradation.seed == 4
    with pytest.raises(ValueError, match="unknown segmenter 'sam3'; choose one of simulator"):
        make_segmenter("sam3")
