import math
from pathlib import Path

import pytest

from bimanualshift.utils.workers import run_jobs


def test_jobs_give_the_same_results_in_process_and_in_spawned_workers() -> None:
    jobs = [1.0, 4.0, 9.0, 16.0, 25.0]
    assert run_jobs(math.sqrt, jobs) == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert sorted(run_jobs(math.sqrt, jobs, workers=2)) == [1.0, 2.0, 3.0, 4.0, 5.0]


def test_job_specs_and_records_cross_as_json() -> None:
    import json

    import numpy as np

    from bimanualshift.evaluation.bench import BenchJob
    from bimanualshift.sim.expert_check import ExpertEpisode
    from bimanualshift.utils.workers import from_json, to_json

    job = BenchJob("bimanualshift", "push_two_buttons", 7, "", {"task": "push_two_buttons", "demos": 3},
                   max_keyframes=4)
    record = ExpertEpisode("lift_ball", 3, True, np.int64(4), 1.5)
    for value in (job, record, ("prior", "task", 9), {"a": [1, (2, 3)]}):
        assert from_json(json.loads(json.dumps(to_json(value)))) == value
    with pytest.raises(TypeError, match="cannot cross"):
        to_json(object())
    with pytest.raises(ValueError, match="only bimanualshift"):
        from_json({"__dataclass__": "subprocess:Popen", "fields": {}})


@pytest.mark.slow
def test_ray_executor_gives_the_local_pool_s_episodes_seed_by_seed(tmp_path: Path) -> None:
    """The same bench episodes (a frozen prior on a bimanual task) as Ray tasks and in the local pool."""
    import ray

    from bimanualshift.evaluation.bench import BenchJob, run_bench_episode

    request = {"task": "push_two_buttons", "data": "", "validation_data": "", "demos": 1, "prior": "peract_suite",
               "out": str(tmp_path), "steps": 1}
    jobs = [BenchJob("frozen_prior_per_arm", "push_two_buttons", seed, "", request, max_keyframes=3)
            for seed in (200_000, 200_001, 200_002)]
    local = sorted(run_jobs(run_bench_episode, jobs, workers=2, chunksize=1), key=lambda e: e["seed"])
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        remote = sorted(run_jobs(run_bench_episode, jobs, executor="ray"), key=lambda e: e["seed"])
    finally:
        ray.shutdown()
    assert remote == local
    assert [e["seed"] for e in remote] == [200_000, 200_001, 200_002]
