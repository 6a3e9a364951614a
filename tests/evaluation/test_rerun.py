"""`--rerun`: a method's stale episodes and training runs move aside, losslessly and once per commit."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from bimanualshift.evaluation.rerun import check_rerun, run_folders, supersede, supersede_all
from bimanualshift.utils.jsonl import read_records

COMMIT = "0123456789abcdef0123456789abcdef01234567"


def _episode(method: str, seed: int) -> dict:
    return {"task": "push_two_buttons", "method": method, "perturbation": "none", "seed": seed, "success": True}


def _results(out: Path, runs: Path, methods: list[str]) -> list[dict]:
    episodes = [_episode(m, s) for m in methods for s in (1, 2)]
    out.mkdir(parents=True)
    (out / "episodes.jsonl").write_text("".join(json.dumps(e) + "\n" for e in episodes))
    (out / "keyframes.jsonl").write_text("".join(json.dumps({**e, "steps": []}) + "\n" for e in episodes))
    (out / "summary.json").write_text(json.dumps({"training": {f"push_two_buttons/{m}": {"best": 1} for m in methods}}))
    (out / "videos").mkdir()
    for m in methods:
        (out / "videos" / f"push_two_buttons_{m}_1.mp4").write_bytes(b"video")
        (runs / "push_two_buttons" / m / "best").mkdir(parents=True)
    return episodes


def test_a_rerun_moves_only_that_methods_records_and_run_and_resumes_at_the_same_commit(tmp_path: Path) -> None:
    out, runs = tmp_path / "out", tmp_path / "runs"
    episodes = _results(out, runs, ["no_residual", "unstructured"])
    archive = supersede("unstructured", out, runs, ["push_two_buttons"], COMMIT)
    assert archive == out / "superseded" / f"unstructured-{COMMIT[:12]}"
    assert read_records(out / "episodes.jsonl") == [e for e in episodes if e["method"] == "no_residual"]
    assert read_records(archive / "episodes.jsonl.gz") == [e for e in episodes if e["method"] == "unstructured"]
    assert [r["method"] for r in read_records(archive / "keyframes.jsonl.gz")] == ["unstructured"] * 2
    assert json.loads((archive / "records.json").read_text())["training"] == {"push_two_buttons/unstructured": {
        "best": 1}}
    assert (archive / "videos" / "push_two_buttons_unstructured_1.mp4").is_file()
    assert [p.name for p in (out / "videos").iterdir()] == ["push_two_buttons_no_residual_1.mp4"]
    assert not (runs / "push_two_buttons" / "unstructured").exists()
    assert (runs / "push_two_buttons" / "superseded" / f"unstructured-{COMMIT[:12]}" / "best").is_dir()
    assert (runs / "push_two_buttons" / "no_residual").is_dir()
    # the re-run's new episodes survive the same command repeated after a kill
    with (out / "episodes.jsonl").open("a") as f:
        f.write(json.dumps(_episode("unstructured", 1)) + "\n")
    assert supersede("unstructured", out, runs, ["push_two_buttons"], COMMIT) is None
    assert [e["method"] for e in read_records(out / "episodes.jsonl")].count("unstructured") == 1
    # a later commit supersedes again, into its own archive
    later = supersede("unstructured", out, runs, ["push_two_buttons"], "f" * 40 + "-dirty")
    assert later is not None and later.name == "unstructured-ffffffffffff-dirty"
    assert read_records(later / "episodes.jsonl.gz") == [_episode("unstructured", 1)]


def test_a_supersede_cut_short_is_redone_without_losing_or_doubling_records(tmp_path: Path) -> None:
    out, runs = tmp_path / "out", tmp_path / "runs"
    episodes = _results(out, runs, ["unstructured"])
    # killed after saving the archive's copy of the episodes, before the log was rewritten
    partial = out / "superseded" / f"unstructured-{COMMIT[:12]}.partial"
    partial.mkdir(parents=True)
    (partial / "episodes.jsonl.gz").write_bytes(gzip.compress((json.dumps(episodes[0]) + "\n").encode()))
    archive = supersede("unstructured", out, runs, ["push_two_buttons"], COMMIT)
    assert read_records(archive / "episodes.jsonl.gz") == episodes
    assert read_records(out / "episodes.jsonl") == [] and not partial.exists()


def test_a_variant_gives_up_its_own_refinement_only_and_a_shared_run_needs_every_recorded_sharer(
        tmp_path: Path) -> None:
    assert run_folders("fixed_memory", "runs", ["lift_ball"]) == [Path("runs/lift_ball/bimanualshift/refine_none")]
    assert run_folders("unstructured", "runs", ["lift_ball"]) == [Path("runs/lift_ball/unstructured")]
    out = tmp_path / "out"
    _results(out, tmp_path / "runs", ["bimanualshift", "no_refinement"])
    with pytest.raises(ValueError, match="no_refinement also come from.*add no_refinement to --rerun"):
        check_rerun(["bimanualshift"], ["bimanualshift", "no_refinement"], out)
    with pytest.raises(ValueError, match="not among --methods"):
        check_rerun(["unstructured"], ["bimanualshift"], out)
    check_rerun(["bimanualshift", "no_refinement"], ["bimanualshift", "no_refinement"], out)
    report = supersede_all(["bimanualshift", "no_refinement"], ["bimanualshift", "no_refinement"], out,
                           tmp_path / "runs", ["push_two_buttons"], COMMIT)
    assert [r["archive"] is not None for r in report] == [True, True]
    assert read_records(out / "episodes.jsonl") == []


def test_a_task_rerun_moves_that_tasks_records_and_run_only(tmp_path: Path) -> None:
    out, runs = tmp_path / "out", tmp_path / "runs"
    episodes = _results(out, runs, ["peract_lf"])
    other = [{**e, "task": "lift_ball"} for e in episodes]  # the method's finished task stays as it is
    with (out / "episodes.jsonl").open("a") as f:
        f.write("".join(json.dumps(e) + "\n" for e in other))
    summary = json.loads((out / "summary.json").read_text())
    summary["training"]["lift_ball/peract_lf"] = {"best": 2}
    (out / "summary.json").write_text(json.dumps(summary))
    (runs / "lift_ball" / "peract_lf" / "best").mkdir(parents=True)
    (out / "videos" / "lift_ball_peract_lf_1.mp4").write_bytes(b"video")
    report = supersede_all(["push_two_buttons/peract_lf"], ["peract_lf"], out, runs,
                           ["push_two_buttons", "lift_ball"], COMMIT)
    archive = out / "superseded" / f"peract_lf-push_two_buttons-{COMMIT[:12]}"
    assert report == [{"method": "push_two_buttons/peract_lf", "archive": str(archive)}]
    assert read_records(out / "episodes.jsonl") == other
    assert read_records(archive / "episodes.jsonl.gz") == episodes
    assert json.loads((archive / "records.json").read_text())["training"] == {"push_two_buttons/peract_lf": {
        "best": 1}}
    assert [p.name for p in (out / "videos").iterdir()] == ["lift_ball_peract_lf_1.mp4"]
    assert not (runs / "push_two_buttons" / "peract_lf").exists()
    assert (runs / "lift_ball" / "peract_lf" / "best").is_dir()
    # a study's other half, without that task, leaves everything where it is
    assert supersede_all(["push_two_buttons/peract_lf"], ["peract_lf"], out, runs, ["lift_ball"], "e" * 40) == []
    assert read_records(out / "episodes.jsonl") == other


def test_a_task_rerun_names_a_registered_task_and_every_sharer_on_it(tmp_path: Path) -> None:
    out = tmp_path / "out"
    _results(out, tmp_path / "runs", ["bimanualshift", "no_refinement"])
    with pytest.raises(ValueError, match="push_two_button/peract_lf: no such task"):
        check_rerun(["push_two_button/peract_lf"], ["peract_lf"], out)
    with pytest.raises(ValueError, match="add push_two_buttons/no_refinement to --rerun"):
        check_rerun(["push_two_buttons/bimanualshift"], ["bimanualshift", "no_refinement"], out)
    # the sharer recorded on another task only is not in the way
    check_rerun(["lift_ball/bimanualshift"], ["bimanualshift", "no_refinement"], out)
    check_rerun(["push_two_buttons/bimanualshift", "push_two_buttons/no_refinement"],
                ["bimanualshift", "no_refinement"], out)
