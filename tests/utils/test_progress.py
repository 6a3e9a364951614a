"""Progress bars redraw rarely when written to a log file, and the user's own setting wins."""

from __future__ import annotations

import os
import subprocess
import sys

from bimanualshift.utils.progress import LOG_INTERVAL_S, slow_bars_in_logs

# 200 updates over ~1 s: tqdm's default redraws ~10 times, a 30 s interval only at the start and the end.
BAR = ("from bimanualshift.utils.progress import slow_bars_in_logs\n"
       "slow_bars_in_logs(is_terminal=False)\n"
       "import time\nfrom tqdm import tqdm\n"
       "for _ in tqdm(range(200)):\n    time.sleep(0.005)\n")


def test_sets_the_interval_only_for_a_log_file() -> None:
    env: dict[str, str] = {}
    assert slow_bars_in_logs(env, is_terminal=True) is False and env == {}
    assert slow_bars_in_logs(env, is_terminal=False) is True
    assert env["TQDM_MININTERVAL"] == str(LOG_INTERVAL_S)


def test_keeps_the_users_setting() -> None:
    env = {"TQDM_MININTERVAL": "1"}
    assert slow_bars_in_logs(env, is_terminal=False) is False
    assert env["TQDM_MININTERVAL"] == "1"


def _redraws(extra_env: dict[str, str]) -> int:
    env = {k: v for k, v in os.environ.items() if not k.startswith("TQDM_")} | extra_env
    done = subprocess.run([sys.executable, "-c", BAR], capture_output=True, env=env, timeout=60,
                          check=True)
    return done.stderr.count(b"\r")  # bytes: text mode would turn each \r into \n


def test_a_logged_bar_redraws_far_less_than_tqdms_default() -> None:
    logged = _redraws({})
    default = _redraws({"TQDM_MININTERVAL": "0.1"})
    assert logged <= 3 < default


# the training loop's bar, whose loss is updated at every step: 300 steps of a tiny model
TRAINING = ("import sys, torch\n"
            "from bimanualshift.utils.progress import slow_bars_in_logs\n"
            "slow_bars_in_logs(is_terminal=False)\n"
            "from bimanualshift.training.loop import run_training\n"
            "model = torch.nn.Linear(2, 1)\n"
            "optimizer = torch.optim.SGD(model.parameters(), lr=0.01)\n"
            "def step_fn(step, gen):\n"
            "    return {'total': model(torch.randn(4, 2, generator=gen)).pow(2).mean()}\n"
            "run_training(sys.argv[1], model, optimizer, 300, step_fn, seed=0, checkpoint_every=300)\n")


def test_a_training_bars_loss_does_not_force_a_redraw_at_every_step(tmp_path) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("TQDM_")}
    done = subprocess.run([sys.executable, "-c", TRAINING, str(tmp_path)], capture_output=True, env=env,
                          timeout=120, check=True)
    assert done.stderr.count(b"\r") <= 3  # was one redraw per step: the loss's postfix refreshed the bar
