import json
from pathlib import Path

from bimanualshift.cli import main
from bimanualshift.perception.quality import QualityTally


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
