"""Seeded runs of ``companion simulate`` on several processes, results in seed order.

Each run owns its random sources (seeded from its seed alone: simulation.run_once), so a run
flies the same bits whichever process flies it and whatever flew there before: ``jobs`` changes
the wall time, never the JSON (tests/test_simulate_jobs.py). Processes, not threads: the loop is
pure Python and numpy on small arrays, which would serialise on the GIL. Workers are forked where
the platform allows (companion and numpy already imported) and tied to this process's life
(tools/child_lifetime.py), so a simulate killed hard leaves none running.
"""
from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor

from companion.config.scenario import Scenario
from companion.sim.simulation import RunOutcome, run_once
from companion.tools.child_lifetime import die_with_parent_now


def available_cores() -> int:
    """CPUs this process may run on (its affinity, which taskset and cgroup cpusets narrow)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:                    # not on Linux
        return max(1, os.cpu_count() or 1)


def _fly(task: tuple[Scenario, int, str | None]) -> RunOutcome:
    world, seed, strategy = task
    return run_once(world, seed, strategy)


def fly_runs(worlds: Sequence[Scenario], seeds: Sequence[int], strategy: str | None,
             jobs: int, on_done: Callable[[], None] | None = None) -> list[RunOutcome]:
    """``run_once(worlds[i], seeds[i], strategy)`` for every i, on up to ``jobs`` processes
    (1: in this process, as before there were jobs). ``on_done`` after each run, in order."""
    jobs = max(1, min(jobs, len(seeds)))
    tasks = list(zip(worlds, seeds, [strategy] * len(seeds)))
    outcomes: list[RunOutcome] = []
    for outcome in (map(_fly, tasks) if jobs == 1 else _pooled(tasks, jobs)):
        outcomes.append(outcome)
        if on_done is not None:
            on_done()
    return outcomes


def _pooled(tasks: list, jobs: int) -> Iterator[RunOutcome]:
    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    with ProcessPoolExecutor(jobs, mp_context=context, initializer=die_with_parent_now) as pool:
        try:
            # One run per message: a run is 0.05-1 s and its pickled outcome ~60 KB, and a chunk
            # of several would leave one process flying the last chunk alone.
            yield from pool.map(_fly, tasks)
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise
