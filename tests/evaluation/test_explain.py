"""`bimanualshift explain`: a failed episode's first divergence from the expert, per arm."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bimanualshift.evaluation.explain import (
    Divergence,
    explain_rows,
    explain_text,
    explained_seeds,
    first_divergence,
)


def _row(x: float, gripper: float = 1.0) -> list[float]:
    return [x, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, gripper, 0.0]


def _step(k: int, executed: list, expert: list | None, stages: int = 0) -> dict:
    return {"keyframe": k, "executed": executed, "expert": expert, "stages_done": stages}


def _write_episodes(folder: Path, steps_by_seed: dict[int, list[dict]], successes: int) -> None:
    """A bench folder of task "t", method "m": the first ``successes`` seeds succeed."""
    seeds = list(steps_by_seed)
    (folder / "episodes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": "m", "seed": s, "success": s in seeds[:successes],
                    "keyframes": len(steps_by_seed[s]), "stages_done": 0}) + "\n" for s in seeds))
    (folder / "keyframes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": "m", "seed": s, "steps": steps}) + "\n"
        for s, steps in steps_by_seed.items()))


def test_first_divergence_names_the_keyframe_the_arm_and_what_strayed() -> None:
    steps = [_step(0, [_row(0.5), _row(0.2)], [_row(0.51), _row(0.2)]),  # within 3 cm
             _step(1, [_row(0.5), _row(0.2, gripper=0.0)], [_row(0.5), _row(0.2)]),
             _step(2, [_row(0.9), _row(0.2)], [_row(0.5), _row(0.2)])]
    assert first_divergence(steps) == Divergence(1, "right", "gripper")
    assert first_divergence(steps[2:]) == Divergence(2, "left", "position")
    assert first_divergence(steps[:1]) is None  # followed the expert throughout (and failed anyway: too slow)
    assert first_divergence([_step(5, [_row(0.5)] * 2, None)]) == Divergence(5, "-", "past the expert's plan")


def test_a_gripper_turned_half_way_round_follows_the_expert() -> None:
    turned = [0.5, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0]  # a half turn about the gripper's own z
    quarter = [0.5, 0.0, 1.0, 0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5), 1.0, 0.0]
    assert first_divergence([_step(0, [turned, _row(0.2)], [_row(0.5), _row(0.2)])]) is None
    assert first_divergence([_step(0, [quarter, _row(0.2)], [_row(0.5), _row(0.2)])]) == Divergence(0, "left",
                                                                                                 "rotation")


def test_explain_summarises_failures_per_method(tmp_path: Path) -> None:
    episodes = [{"task": "t", "method": "m", "seed": s, "success": s == 0, "keyframes": 3, "stages_done": s % 2}
                for s in range(3)]
    good = [_step(0, [_row(0.5), _row(0.2)], [_row(0.5), _row(0.2)])]
    bad = good + [_step(1, [_row(0.9), _row(0.2)], [_row(0.5), _row(0.2)])]
    logs = [{"task": "t", "method": "m", "seed": s, "steps": steps} for s, steps in ((0, good), (1, bad), (2, good))]
    (tmp_path / "episodes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in episodes))
    (tmp_path / "keyframes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in logs))
    (row,) = explain_rows(tmp_path, "t")
    assert row["failures"] == 2 and row["failed_at_stage"] == {0: 1, 1: 1}
    assert row["first_divergence"] == {"k1 left (position)": 1, "never (too slow)": 1}
    assert "2 of 3 episodes failed" in explain_text([row], "t")
    assert np.isclose(sum(row["first_divergence"].values()), row["failures"])
    with pytest.raises(ValueError, match="no logged episodes of 'u'"):
        explain_rows(tmp_path, "u")
    (tmp_path / "keyframes.jsonl").unlink()
    with pytest.raises(FileNotFoundError, match="re-run its bench command"):
        explain_rows(tmp_path, "t")


def test_explain_counts_held_keyframes_per_arm_and_stage(tmp_path: Path) -> None:
    def arms(left_held: bool, right_held: bool) -> dict:
        return {"arms": [{"arm": "left", "held": left_held}, {"arm": "right", "held": right_held}]}

    steps = [{**_step(0, [_row(0.5), _row(0.2)], [_row(0.5), _row(0.2)]), "policy": arms(False, True)},
             {**_step(1, [_row(0.5), _row(0.2)], None, stages=1), "policy": arms(True, True)},
             {**_step(2, [_row(0.5), _row(0.2)], None, stages=1), "policy": arms(True, False)}]
    (tmp_path / "episodes.jsonl").write_text(json.dumps({"task": "t", "method": "m", "seed": 0, "success": False,
                                                         "keyframes": 3, "stages_done": 1}) + "\n")
    (tmp_path / "keyframes.jsonl").write_text(json.dumps({"task": "t", "method": "m", "seed": 0, "steps": steps}))
    (row,) = explain_rows(tmp_path, "t")
    assert row["held_arm_keyframes"] == 4
    assert row["held_by_arm_and_stage"] == {"left": {0: [0, 1], 1: [2, 2]}, "right": {0: [1, 1], 1: [1, 2]}}
    assert "right held, by stage reached: stage 0: 1/1, stage 1: 1/2" in explain_text([row], "t")


def test_the_lead_arm_is_the_one_the_expert_moves_first_and_a_role_swap_shows() -> None:
    from bimanualshift.evaluation.explain import lead_arms

    # the expert moves the right arm 10 cm a keyframe while the left waits; the policy moves the left instead
    expert = [[_row(0.5), _row(0.1 * k)] for k in range(4)]
    swapped = [_step(k, [_row(0.5 + 0.1 * k), _row(0.0)], expert[k]) for k in range(4)]
    followed = [_step(k, [_row(0.5), _row(0.1 * k + 0.01)], expert[k]) for k in range(4)]
    assert lead_arms(swapped) == ("right", "left")
    assert lead_arms(followed) == ("right", "right")
    # both arms reaching together: no leader, nothing to count
    together = [_step(k, [_row(0.5), _row(0.0)], [_row(0.1 * k), _row(0.1 * k)]) for k in range(4)]
    assert lead_arms(together) is None
    assert lead_arms(swapped[:1]) is None  # one keyframe: no motion to compare


def test_explain_counts_episodes_led_by_the_expert_s_lead_arm(tmp_path: Path) -> None:
    expert = [[_row(0.5), _row(0.1 * k)] for k in range(4)]
    swapped = [_step(k, [_row(0.5 + 0.1 * k), _row(0.0)], expert[k]) for k in range(4)]
    followed = [_step(k, [_row(0.5), _row(0.1 * k)], expert[k]) for k in range(4)]
    (tmp_path / "episodes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": "m", "seed": s, "success": False, "keyframes": 4}) + "\n"
        for s in range(3)))
    (tmp_path / "keyframes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": "m", "seed": s, "steps": steps}) + "\n"
        for s, steps in enumerate((swapped, followed, followed))))
    (row,) = explain_rows(tmp_path, "t")
    assert row["same_lead_arm"] == {"right": [2, 3]}
    assert "moved first the arm the expert leads with: 2/3 episodes (by the expert's lead arm: right 2/3)" in \
        explain_text([row], "t")


def test_explain_command_takes_methods_as_bench_does_and_names_an_unknown_one(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from bimanualshift.cli import main

    steps = [_step(0, [_row(0.5), _row(0.2)], [_row(0.9), _row(0.2)])]
    (tmp_path / "episodes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": m, "seed": 0, "success": False, "keyframes": 1}) + "\n" for m in "ab"))
    (tmp_path / "keyframes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": m, "seed": 0, "steps": steps}) + "\n" for m in "ab"))
    for flag in ("--methods", "--method"):
        main(["explain", str(tmp_path), "--task", "t", flag, "b"])
        out = capsys.readouterr().out
        assert "## b: 1 of 1 episodes failed" in out and "## a:" not in out
    with pytest.raises(ValueError, match="no logged episodes of c on 't'.*logged methods: a, b"):
        explain_rows(tmp_path, "t", ["b", "c"])


def _retrieving_step(k: int, x: float, entry: int | None, source: str | None = None) -> dict:
    retrieval = {"similarity": 0.99, "fired": entry is not None, "entry": entry}
    if source is not None:
        retrieval["source"] = source
    return {**_step(k, [_row(x), _row(0.2)], [_row(0.5), _row(0.2)]), "policy": {"arms": [], "retrieval": retrieval}}


def test_the_reference_s_source_comes_from_the_log_or_from_the_memory_s_size() -> None:
    from bimanualshift.evaluation.explain import retrieval_source

    assert retrieval_source({"fired": True, "entry": 3, "source": "refinement"}, None, True) == "refinement"
    assert retrieval_source({"fired": False, "entry": None}, 10, True) == "none"
    assert retrieval_source(None, 10, True) == "none"
    # an older log: refinement appends after the demos' entries
    assert retrieval_source({"fired": True, "entry": 9}, 10, True) == "demo"
    assert retrieval_source({"fired": True, "entry": 10}, 10, True) == "refinement"
    assert retrieval_source({"fired": True, "entry": 12}, None, False) == "demo"  # never refined
    assert retrieval_source({"fired": True, "entry": 12}, None, True) == "unknown"


def test_explain_splits_episodes_by_the_reference_s_source_and_against_another_method(tmp_path: Path) -> None:
    import gzip

    # the refined method "r" follows refinement entries (index >= 2 in an older log) on seeds 0 and 1 and a demo
    # entry on seed 2; the unrefined "u" succeeds on seeds 0 and 2 and acts the same where r followed a demo
    outcomes = {("r", 0): False, ("r", 1): True, ("r", 2): True, ("u", 0): True, ("u", 1): False, ("u", 2): True}
    steps = {("r", 0): [_retrieving_step(0, 0.5, 2), _retrieving_step(1, 0.9, 2)],
             ("r", 1): [_retrieving_step(0, 0.52, 3), _retrieving_step(1, 0.5, 3)],
             ("r", 2): [_retrieving_step(0, 0.5, 1), _retrieving_step(1, 0.5, 1)],
             **{("u", s): [_retrieving_step(0, 0.5, 1, "demo"), _retrieving_step(1, 0.5, 1, "demo")]
                for s in range(3)}}
    (tmp_path / "episodes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": m, "seed": s, "success": ok, "keyframes": 2}) + "\n"
        for (m, s), ok in outcomes.items()))
    with gzip.open(tmp_path / "keyframes.jsonl.gz", "wt") as f:  # an archived folder's log
        f.write("".join(json.dumps({"task": "t", "method": m, "seed": s, "steps": st}) + "\n"
                        for (m, s), st in steps.items()))
    (tmp_path / "summary.json").write_text(json.dumps(
        {"refinement": {"t/r": {"memory_entries": 4, "inserted_into_memory": 2}}}))
    # "r" stands in for a refined method: the summary's record is what marks it refined here
    rows = {r["method"]: r for r in explain_rows(tmp_path, "t", ["r"], against="u")}
    assert rows["r"]["by_retrieval_source"] == {"demo": {"episodes": 1, "successes": 1},
                                                "refinement": {"episodes": 2, "successes": 1}}
    assert rows["u"]["by_retrieval_source"] == {"demo": {"episodes": 3, "successes": 2}}
    versus = rows["r"]["against"]
    assert versus["method"] == "u"
    assert versus["by_source"]["refinement"] == {
        "episodes": 2, "successes": 1, "other_successes": 1, "won": 1, "lost": 1,
        "first_keyframe_shift_cm": [0.0, 2.0], "parted_at_keyframe": {"1": 1, "None": 1}}
    assert versus["by_source"]["demo"]["parted_at_keyframe"] == {"None": 1}
    assert rows["r"]["failed_episodes"][0]["first_keyframe_error_cm"] == {"left": 0.0, "right": 0.0}
    assert rows["r"]["failed_episodes"][0]["retrieval_entry"] == 2
    text = explain_text(list(rows.values()), "t")
    assert "successes by the reference's source: demo 1/1, refinement 1/2" in text
    assert "refinement: 2 episodes, 1 vs 1 successes, 1 won, 1 lost" in text
    with pytest.raises(ValueError, match="no logged episodes of v on 't'"):
        explain_rows(tmp_path, "t", ["r"], against="v")


def test_explain_reports_the_first_keyframe_s_error_and_residual_for_failures_and_successes(tmp_path: Path) -> None:
    def first(x: float, residual_cm: float) -> dict:
        return {**_step(0, [_row(x), _row(0.2)], [_row(0.5), _row(0.2)]),
                "policy": {"arms": [{"arm": "left", "residual_cm": residual_cm}, {"arm": "right", "residual_cm": 1.0}]}}

    # seeds 0-1 succeed 1 cm from the expert; seeds 2-4 fail 10, 20 and 30 cm away
    offsets = {0: 0.01, 1: 0.01, 2: 0.1, 3: 0.2, 4: 0.3}
    (tmp_path / "episodes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": "m", "seed": s, "success": s < 2, "keyframes": 1, "stages_done": 0}) + "\n"
        for s in offsets))
    (tmp_path / "keyframes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": "m", "seed": s, "steps": [first(0.5 + dx, 100 * dx + 5)]}) + "\n"
        for s, dx in offsets.items()))
    (row,) = explain_rows(tmp_path, "t")
    assert row["first_keyframe_cm"]["failures"] == {"left error": 20.0, "right error": 0.0, "left residual": 25.0,
                                                   "right residual": 1.0}
    assert row["first_keyframe_cm"]["successes"]["left error"] == 1.0
    assert "first keyframe, failures (median cm from the expert; residual added; prior turn: degrees from the " \
           "expert's): left error 20.0" in explain_text([row], "t")


def test_explain_reports_how_far_the_prior_s_first_proposal_turns_from_the_expert_s(tmp_path: Path) -> None:
    r = np.sqrt(0.5)
    quarter_turn = [0.0, 0.0, r, r]  # yawed 90 degrees about the approach axis from the rows' identity (x, y, z, w)
    half_turn = [0.0, 0.0, 1.0, 0.0]  # the same grasp for a parallel gripper

    def first(quat: list[float]) -> dict:
        return {**_step(0, [_row(0.5), _row(0.2)], [_row(0.5), _row(0.2)]),
                "policy": {"arms": [{"arm": "left", "prior": [0.5, 0.0, 1.0, *quat], "residual_cm": 1.0},
                                    {"arm": "right", "prior": _row(0.2)[:7], "residual_cm": 1.0}]}}

    (tmp_path / "episodes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": "m", "seed": s, "success": s < 2, "keyframes": 1, "stages_done": 0})
        + "\n" for s in range(3)))
    (tmp_path / "keyframes.jsonl").write_text("".join(
        json.dumps({"task": "t", "method": "m", "seed": s, "steps": [first(q)]}) + "\n"
        for s, q in ((0, _row(0.5)[3:7]), (1, half_turn), (2, quarter_turn))))
    (row,) = explain_rows(tmp_path, "t")
    assert row["first_keyframe_cm"]["successes"]["left prior turn"] == pytest.approx(0.0, abs=1e-3)
    assert row["first_keyframe_cm"]["failures"]["left prior turn"] == pytest.approx(90.0)
    assert row["first_keyframe_cm"]["failures"]["right prior turn"] == 0.0


def test_explain_shows_where_failures_part_from_successes_when_both_diverge_first_at_the_same_place(
        tmp_path: Path) -> None:
    # every episode's left arm starts 5 cm off (the first divergence of all four); the failures' right arm then
    # lands 8 cm off at keyframe 2 where the successes' lands 1 cm off
    def steps(right_off: float) -> list[dict]:
        return [_step(0, [_row(0.55), _row(0.2)], [_row(0.5), _row(0.2)]),
                _step(1, [_row(0.5), _row(0.2)], [_row(0.5), _row(0.2)]),
                _step(2, [_row(0.5), _row(0.2 + right_off)], [_row(0.5), _row(0.2)])]

    offsets = {0: 0.01, 1: 0.01, 2: 0.08, 3: 0.08}
    _write_episodes(tmp_path, {s: steps(dx) for s, dx in offsets.items()}, successes=2)
    (row,) = explain_rows(tmp_path, "t")
    assert row["first_divergence"] == {"k0 left (position)": 2}
    assert row["successes_first_divergence"] == {"k0 left (position)": 2}
    assert row["keyframe_profile"]["failures"]["right"] == [[0.0, 0.0], [0.0, 0.0], [8.0, 0.0]]
    assert row["keyframe_profile"]["successes"]["right"][2] == [1.0, 0.0]
    text = explain_text([row], "t")
    assert "where the successes diverge first too: 2 x k0 left (position)" in text
    assert "failures part most from the successes at k2 right (position): median 8.0 against 1.0 cm" in text
    assert "right from the expert per keyframe (cm/degrees, failures | successes): k0 0/0 | 0/0" in text


def test_explain_shows_where_the_failures_arms_stop_short_of_their_command(tmp_path: Path) -> None:
    # every episode is sent where the expert goes; the failures' left arm ends 6 cm short of it at keyframe 1
    def steps(short: float) -> list[dict]:
        sent = [_row(0.5), _row(0.2)]
        return [{**_step(0, sent, sent), "reached": [r[:8] for r in sent]},
                {**_step(1, sent, sent), "reached": [_row(0.5 - short)[:8], _row(0.2)[:8]]}]

    shorts = {0: 0.0, 1: 0.0, 2: 0.06, 3: 0.06}
    _write_episodes(tmp_path, {s: steps(d) for s, d in shorts.items()}, successes=2)
    (row,) = explain_rows(tmp_path, "t")
    assert row["first_divergence"] == {"never (too slow)": 2}  # the commands never strayed
    assert row["tracking_profile"]["failures"]["left"] == [[0.0, 0.0], [6.0, 0.0]]
    text = explain_text([row], "t")
    assert ("the arms stop short of their command most apart from the successes at k1 left (position): median 6.0 "
            "against 0.0 cm from where they were sent") in text


def test_explain_names_a_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="is not a folder: give a bench or study run's result folder"):
        explain_rows(tmp_path / "nope", "t")


def test_explained_seeds_are_the_seeds_the_rows_cover() -> None:
    rows = [{"method": "a", "seeds": [3, 1]}, {"method": "b", "seeds": [2, 1]}]
    assert explained_seeds(rows) == {"test": [1, 2, 3]}


def test_explain_narrows_to_one_perturbation(tmp_path: Path) -> None:
    good = [_step(0, [_row(0.5), _row(0.2)], [_row(0.5), _row(0.2)])]
    episodes, logs = [], []
    for perturbation, success in (("none", True), ("glare", False)):
        for seed in range(2):
            key = {"task": "t", "method": "m", "perturbation": perturbation, "seed": seed}
            episodes.append({**key, "success": success, "keyframes": 1, "stages_done": 0})
            logs.append({**key, "steps": good})
    (tmp_path / "episodes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in episodes))
    (tmp_path / "keyframes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in logs))
    assert explain_rows(tmp_path, "t")[0]["episodes"] == 4
    (glare,) = explain_rows(tmp_path, "t", perturbation="glare")
    assert (glare["episodes"], glare["failures"]) == (2, 2)
    with pytest.raises(ValueError, match="logged perturbations: glare, none"):
        explain_rows(tmp_path, "t", perturbation="fog")
