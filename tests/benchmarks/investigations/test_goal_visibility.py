"""benchmarks/investigations/goal_visibility.py counts each goal noun's pixels per keyframe of the demos."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from bimanualshift.data.episode import read_episode

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "benchmarks" / "investigations" / "goal_visibility.py"


def test_counts_each_goal_nouns_pixels_per_keyframe(demo_root: Path, tmp_path: Path) -> None:
    out = tmp_path / "visibility.json"
    done = subprocess.run([sys.executable, str(SCRIPT), "--tasks", "push_two_buttons", "--demos", "2", "--data",
                           str(demo_root / "bimanual"), "--out", str(out)], capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    result = json.loads(out.read_text())
    episode = read_episode(sorted((demo_root / "bimanual" / "push_two_buttons").glob("*.h5"))[0])
    rows = [r for r in result["rows"] if r["keyframe"] == 0]
    assert sorted(r["goal_noun"] for r in rows) == sorted(set(episode.goal_nouns) | {
        n for p in (demo_root / "bimanual" / "push_two_buttons").glob("*.h5") for n in read_episode(p).goal_nouns})
    # the simulator's instance ids give the truth: each named button's pixels over every camera, first demo
    noun = episode.goal_nouns[0]
    button = next(i for i, n in enumerate(episode.instance_names)
                  if n.startswith("button") and noun.split()[0] in episode.instance_colours[n])
    truth = int(np.sum(episode["instance"][0] == button))
    counts = [r for r in rows if r["goal_noun"] == noun][0]
    assert counts["min_pixels"] <= truth <= counts["max_pixels"] and truth > 0
    assert result["seeds"]["push_two_buttons"] == [0, 1]


def test_a_task_without_demos_is_named(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, str(SCRIPT), "--tasks", "lift_ball", "--data", str(tmp_path)],
                          capture_output=True, text=True, cwd=ROOT)
    assert done.returncode != 0 and "lift_ball" in done.stderr and "Traceback" not in done.stderr
