"""interrupt.Background: jobs on forked workers beside the main process's own work, collected
where needed (the diagnosis' bootstrap and hybrid trainings, core.diagnose)."""
import os
import time

import pytest

from hpddo import interrupt


def _square(x):
    return x * x


def _pid_after(s):
    time.sleep(s)
    return os.getpid()


def _fails(x):
    raise ValueError(f"job {x} failed")


@pytest.mark.parametrize("workers", [0, 1, 2])
def test_results_in_order_whatever_runs_them(workers):
    """Every job's result is its own, in whatever process and order it ran; the main process does
    queued jobs itself while it waits (with no worker, all of them)."""
    with interrupt.Background(workers) as bg:
        tasks = [bg.submit(_square, k, priority=k % 3) for k in range(20)]
        assert [t.result() for t in tasks] == [k * k for k in range(20)]


def test_a_worker_runs_beside_the_main_process():
    """With a worker, a job submitted first runs there while the main process goes on; the main
    process then does the next queued one itself instead of waiting."""
    with interrupt.Background(1) as bg:
        first = bg.submit(_pid_after, 1.0)
        time.sleep(0.3)  # the worker has taken it
        second = bg.submit(_pid_after, 0.0)
        assert second.result() == os.getpid()  # done here while the worker is busy
        assert first.result() != os.getpid()


def _started(_):
    return time.monotonic()


def test_lowest_priority_number_first():
    """Queued jobs are taken lowest priority first, then in the order given: here by the main
    process, while it waits for the one job the worker runs."""
    with interrupt.Background(1) as bg:
        blocker = bg.submit(_pid_after, 1.0)
        time.sleep(0.3)  # the worker has taken it
        tasks = {name: bg.submit(_started, name, priority=p) for name, p in (("a", 2), ("b", 0), ("c", 1), ("d", 0))}
        blocker.result()
        started = {name: t.result() for name, t in tasks.items()}
        assert sorted(started, key=started.get) == ["b", "d", "c", "a"]


@pytest.mark.parametrize("workers", [0, 1])
def test_an_error_comes_back_where_the_result_is_asked(workers):
    with interrupt.Background(workers) as bg:
        bad, good = bg.submit(_fails, 3), bg.submit(_square, 4)
        with pytest.raises(ValueError, match="job 3 failed"):
            bad.result()
        assert good.result() == 16


def test_a_cancelled_job_never_runs_and_leaving_drops_the_queue():
    with interrupt.Background(0) as bg:
        ran = []
        t = bg.submit(ran.append, 1)
        t.cancel()
        bg.submit(ran.append, 2)  # never asked for: dropped on leaving
    assert ran == [] and t.state == "cancelled"


@pytest.mark.parametrize("workers", [0, 1])
def test_a_cancelled_job_asked_for_after_all_runs_here(workers):
    """A job cancelled as not needed (the diagnosis's every-effect fit once a recording is left out) whose
    result is then asked for runs in this process: result() does not wait for a job no one will run."""
    with interrupt.Background(workers) as bg:
        t = bg.submit(_square, 5)
        if workers:
            bg.submit(_square, 6).result()  # (the worker busy first, so that t is still queued)
        t.cancel()
        assert t.result() == 25 and t.state == "done"



def _blas_threads(_):
    import threadpoolctl

    return {m["internal_api"]: m["num_threads"] for m in threadpoolctl.threadpool_info()
            if m["user_api"] == "blas"}


def test_one_blas_thread_per_process_while_workers_run():
    """Beside a worker, the main process and the worker each use one BLAS thread (one_blas_thread):
    two processes whose BLAS spread over both cores would wait on each other's threads. The main
    process's own setting comes back when the block ends."""
    import numpy  # noqa: F401 (its BLAS loaded, so threadpoolctl sees it)

    before = _blas_threads(None)
    assert before, "no BLAS library seen by threadpoolctl"
    with interrupt.Background(1) as bg:
        assert set(_blas_threads(None).values()) == {1}
        in_worker = bg._executor().submit(_blas_threads, None)  # (straight to the pool: run by the worker)
        assert set(in_worker.result().values()) == {1}
        assert bg.submit(_square, 3).result() == 9
    assert _blas_threads(None) == before
