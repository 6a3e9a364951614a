"""benchmarks/paired_comparison.py pairs two methods' episodes on the same seeds (and perturbations)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "paired_comparison.py"


def _write_episodes(folder: Path) -> None:
    rows = []
    # on "none" a wins seeds 0 and 1, b wins none; on "glare" b wins seed 2
    for perturbation, a_flags, b_flags in (("none", [1, 1, 1], [0, 0, 1]), ("glare", [0, 1, 0], [0, 1, 1])):
        for method, flags in (("a", a_flags), ("b", b_flags)):
            rows += [{"task": "t", "method": method, "perturbation": perturbation, "seed": seed, "success": bool(f)}
                     for seed, f in enumerate(flags)]
    folder.mkdir(parents=True)
    (folder / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, cwd=ROOT)


def test_pairs_one_perturbation_or_all(tmp_path: Path) -> None:
    _write_episodes(tmp_path / "f")
    done = _run(str(tmp_path / "f"), "--methods", "a", "b", "--out", str(tmp_path / "none.json"))
    assert done.returncode == 0, done.stderr
    rows = {r["task"]: r for r in json.loads((tmp_path / "none.json").read_text())["rows"]}
    assert (rows["t"]["pairs"], rows["t"]["a_wins"], rows["t"]["b_wins"]) == (3, 2, 0)

    done = _run(str(tmp_path / "f"), "--methods", "a", "b", "--perturbation", "all",
                "--out", str(tmp_path / "all.json"))
    assert done.returncode == 0, done.stderr
    rows = {r["task"]: r for r in json.loads((tmp_path / "all.json").read_text())["rows"]}
    assert (rows["t (glare)"]["a_wins"], rows["t (glare)"]["b_wins"]) == (0, 1)
    assert (rows["all"]["pairs"], rows["all"]["a_wins"], rows["all"]["b_wins"]) == (6, 2, 1)


def test_an_unknown_perturbation_names_the_ones_recorded(tmp_path: Path) -> None:
    _write_episodes(tmp_path / "f")
    done = _run(str(tmp_path / "f"), "--methods", "a", "b", "--perturbation", "fog")
    assert done.returncode != 0
    assert "glare, none" in done.stderr and "Traceback" not in done.stderr


def test_method_b_from_another_folder(tmp_path: Path) -> None:
    _write_episodes(tmp_path / "f")
    rows = [{"task": "t", "method": "b", "perturbation": "none", "seed": seed, "success": True}
            for seed in (0, 1, 2, 9)]
    (tmp_path / "g").mkdir()
    (tmp_path / "g" / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    done = _run(str(tmp_path / "f"), "--methods", "a", "b", "--against", str(tmp_path / "g"),
                "--out", str(tmp_path / "against.json"))
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "against.json").read_text())
    rows = {r["task"]: r for r in result["rows"]}
    # a's episodes from f (1, 1, 1), b's from g (all solved): no win either way; f's own b episodes are not read
    assert (rows["t"]["pairs"], rows["t"]["a_wins"], rows["t"]["b_wins"]) == (3, 0, 0)
    assert str(tmp_path / "g") in result["notes"]
    missing = _run(str(tmp_path / "f"), "--methods", "a", "b", "--against", str(tmp_path / "nowhere"))
    assert missing.returncode != 0 and "nowhere" in missing.stderr and "Traceback" not in missing.stderr


def test_one_methods_two_runs(tmp_path: Path) -> None:
    _write_episodes(tmp_path / "f")
    rows = [{"task": "t", "method": "a", "perturbation": "none", "seed": seed, "success": seed == 0}
            for seed in range(3)]
    (tmp_path / "rerun").mkdir()
    (tmp_path / "rerun" / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    done = _run(str(tmp_path / "f"), "--methods", "a", "a", "--against", str(tmp_path / "rerun"),
                "--out", str(tmp_path / "twice.json"))
    assert done.returncode == 0, done.stderr
    row = json.loads((tmp_path / "twice.json").read_text())["rows"][0]
    assert (row["pairs"], row["a_wins"], row["a@rerun_wins"]) == (3, 2, 0)  # f's a solved all three, rerun's one
    same = _run(str(tmp_path / "f"), "--methods", "a", "a")
    assert same.returncode != 0 and "twice" in same.stderr


def test_a_study_folder_pairs_every_task_group(tmp_path: Path) -> None:
    for group, task, b_flags in (("simple", "s", [0, 0, 1]), ("complex", "c", [1, 1, 1])):
        rows = [{"task": task, "method": method, "seed": seed, "success": bool(f)}
                for method, flags in (("a", [1, 1, 1]), ("b", b_flags)) for seed, f in enumerate(flags)]
        (tmp_path / "study" / group).mkdir(parents=True)
        (tmp_path / "study" / group / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    done = _run(str(tmp_path / "study"), "--methods", "a", "b")
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "study" / "paired_a_vs_b.json").read_text())
    rows = {r["task"]: r for r in result["rows"]}
    assert (rows["s"]["a_wins"], rows["c"]["a_wins"], rows["all"]["pairs"], rows["all"]["a_wins"]) == (2, 0, 6, 2)
    (tmp_path / "empty" / "sub").mkdir(parents=True)
    empty = _run(str(tmp_path / "empty"), "--methods", "a", "b")
    assert empty.returncode != 0 and "subfolders" in empty.stderr and "Traceback" not in empty.stderr
