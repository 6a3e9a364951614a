import numpy as np

from bimanualshift.perception.segmenters.base import CameraView
from bimanualshift.perception.segmenters.simulator import SimulatorSegmenter


def _view(colours: list[list[str]] | None) -> CameraView:
    """Three 4x4 buttons (instances 1-3) on one image, painted navy, blue and cyan."""
    instance = np.zeros((4, 12), np.int16)
    for i in range(3):
        instance[:, 4 * i:4 * i + 4] = i + 1
    class_ids = (instance > 0).astype(np.int16)
    return CameraView(np.zeros((4, 12, 3), np.uint8), instance, class_ids, ["background", "button"], colours)


def test_a_colour_prompt_answers_only_the_objects_painted_that_colour() -> None:
    view = _view([[], ["navy"], ["blue"], ["cyan"]])
    found = SimulatorSegmenter().segment(view, ["blue button", "navy button"])
    assert [(d.label, int(view.instance[d.mask][0])) for d in found] == [("blue button", 2), ("navy button", 1)]
    assert len(SimulatorSegmenter().segment(view, ["button"])) == 3  # the bare noun: every button
    assert SimulatorSegmenter().segment(view, ["red button"]) == []


def test_without_colours_a_colour_prompt_answers_its_whole_class() -> None:
    found = SimulatorSegmenter().segment(_view(None), ["blue button"])
    assert len(found) == 3 and {d.label for d in found} == {"blue button"}
