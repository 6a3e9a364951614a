import math

from bimanualshift.utils.workers import run_jobs


def test_jobs_give_the_same_results_in_process_and_in_spawned_workers() -> None:
    jobs = [1.0, 4.0, 9.0, 16.0, 25.0]
    assert run_jobs(math.sqrt, jobs) == [1.0, 2.0, 3.0, 4.0, 5.0]
    assert sorted(run_jobs(math.sqrt, jobs, workers=2)) == [1.0, 2.0, 3.0, 4.0, 5.0]
