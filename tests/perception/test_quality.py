import json
from pathlib import Path

import numpy as np
import pytest

from bimanualshift.cli import main
from bimanualshift.perception.quality import QualityTally, goal_instances


def test_tally_rates() -> None:
    tally = QualityTally()
    tally.add("left", wanted=10, kept=9, other=20, leaked=2)
    tally.add("left", wanted=10, kept=10, other=0, leaked=0)
    assert tally.rates("left") == (19 / 20, 1 - 2 / 20)


def test_projection_quality_command_writes_rows(tmp_path: Path) -> None:
    out = tmp_path / "quality.json"
    main(["projection-quality", "--task", "pick_up_plate", "--episodes", "1", "--segmenters", "simulator",
          "degraded-strong", "--image-size", "48", "--out", str(out)])
    result = json.loads(out.read_text())
    rows = {(r["segmenter"], r["arm"]): r for r in result["rows"]}
    assert set(rows) == {(s, a) for s in ("simulator", "degraded-strong") for a in ("left", "right")}
    for arm in ("left", "right"):
        clean, noisy = rows[("simulator", arm)], rows[("degraded-strong", arm)]
        assert clean["kept"] > 0.9 and clean["removed"] > 0.9
        assert noisy["kept"] <= clean["kept"] + 1e-9 or noisy["removed"] <= clean["removed"] + 1e-9
        assert clean["keyframes"] == 5  # the first observation + the expert's 4 keyframes


def test_goal_instances_follow_colour_prompts() -> None:
    classes = ["table", "button", "ball"]
    names = ["table", "button_0", "button_1", "button_2", "ball"]
    instance_class = np.array([0, 1, 1, 1, 2])
    colours = {"button_0": ["navy"], "button_1": ["olive"], "button_2": ["teal"]}
    assert goal_instances(instance_class, classes, ["navy button", "teal button"], names, colours) == [1, 3]
    assert goal_instances(instance_class, classes, ["button"], names, colours) == [1, 2, 3]
    assert goal_instances(instance_class, classes, ["ball"], names, {}) == [4]


def test_goal_instances_reject_a_prompt_naming_nothing() -> None:
    classes = ["table", "rope"]
    with pytest.raises(ValueError, match="rope_B_first"):
        goal_instances(np.array([0, 1]), classes, ["rope_B_first"], ["table", "rope"], {})
    with pytest.raises(ValueError, match="red button"):
        goal_instances(np.array([0, 1]), ["table", "button"], ["red button"], ["table", "button_0"],
                       {"button_0": ["navy"]})
