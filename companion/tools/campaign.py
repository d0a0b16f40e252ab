"""Campaigns: many seeded ``simulate`` runs, or many tlog replays, spread over a Dask cluster.

The work is cut into chunks of consecutive run indices; a chunk is one Dask task. Run i of a row
flies seed S+i (and, for random worlds, world S+i), exactly as ``companion simulate`` does, so a
campaign's results do not depend on how many workers ran it or where. Tasks receive only small
picklable values (the Scenario dataclass, the world kind, seeds, the strategy) and return only
what the aggregate needs: each run's summary dict and its pose-NEES sequence, never the traces.

Dask is optional (``pip install .[cluster]``): it is imported only when a cluster is used
(:func:`require_dask`), so this module, and the functions the workers run, import without it.
"""
from __future__ import annotations

import dataclasses
import glob
import logging
import math
import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from companion.config.scenario import Scenario
from companion.config.sections import AvoidanceConfig
from companion.config.loader import FieldError
from companion.core.navigation.decider import STRATEGIES
from companion.errors import CompanionError
from companion.sim.aggregate import aggregate_summaries
from companion.sim.simulation import run_once
from companion.sim.worlds import random_world

log = logging.getLogger(__name__)

# About this many tasks per worker: enough to balance runs of uneven length (long legs, detours)
# across workers, few enough that scheduling (a few ms per task) stays negligible.
TASKS_PER_WORKER = 32
MAX_RUNS_PER_TASK = 25


class DaskMissing(CompanionError):
    """The cluster extra is not installed."""


@dataclass(frozen=True)
class Batch:
    """What every run of one campaign row shares. Small and picklable: it is shipped to workers."""
    scenario: Scenario          # the base scenario, with the row's sweep value applied
    kind: str | None            # random-world kind, or None to fly ``scenario`` itself
    strategy: str

    def world(self, seed: int) -> Scenario:
        return random_world(self.scenario, self.kind, seed) if self.kind else self.scenario

    @property
    def label(self) -> str:
        return f"random-{self.kind}" if self.kind else self.scenario.name


@dataclass(frozen=True)
class RunResult:
    """What a worker returns for one run: the summary and the pose NEES per step, (steps,)."""
    summary: dict
    pose_nees: np.ndarray


@dataclass(frozen=True)
class Row:
    """One row of a campaign: a sweep value (None without a sweep) and its runs, in index order."""
    value: object
    batch: Batch
    results: list[RunResult]

    @property
    def summaries(self) -> list[dict]:
        return [r.summary for r in self.results]

    def aggregate(self) -> dict:
        agg = aggregate_summaries(self.summaries, [r.pose_nees for r in self.results],
                                  self.batch.scenario.safety_distance_m)
        agg["strategy"] = self.batch.strategy
        agg["scenario"] = self.batch.label
        return agg


# ------------------------------------------------------------------ what the workers run
def fly(batch: Batch, seed: int) -> RunResult:
    """One run, as ``companion simulate`` flies it: world and noise both drawn from ``seed``."""
    outcome = run_once(batch.world(seed), seed, batch.strategy)
    return RunResult(outcome.summary, np.asarray(outcome.trace.pose_nees, dtype=float))


def fly_chunk(batch: Batch, first_seed: int, count: int) -> list[RunResult]:
    """Runs ``first_seed`` .. ``first_seed + count - 1`` of ``batch``, in order (one Dask task)."""
    return [fly(batch, seed) for seed in range(first_seed, first_seed + count)]


# ------------------------------------------------------------------ planning
def runs_per_task(runs: int, workers: int) -> int:
    """Chunk size: about TASKS_PER_WORKER tasks per worker, at most MAX_RUNS_PER_TASK runs each."""
    return max(1, min(MAX_RUNS_PER_TASK, math.ceil(runs / (max(1, workers) * TASKS_PER_WORKER))))


def chunks(first_seed: int, runs: int, size: int) -> list[tuple[int, int]]:
    """(first seed, count) of each chunk covering seeds first_seed .. first_seed + runs - 1."""
    return [(first_seed + start, min(size, runs - start)) for start in range(0, runs, size)]


def sweepable() -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(AvoidanceConfig))


def parse_sweep(text: str) -> tuple[str, list]:
    """``NAME=V1,V2,...`` into (name, values); NAME is an AvoidanceConfig field such as eta."""
    name, sep, rest = text.partition("=")
    name = name.strip()
    if not sep or not rest.strip():
        raise CompanionError(f"--sweep {text!r}: expected NAME=V1,V2,... (e.g. eta=1.0,1.25,1.5)")
    if name not in sweepable():
        raise CompanionError(f"--sweep {text!r}: unknown parameter {name!r} "
                             f"(expected one of {', '.join(sweepable())})")
    values = []
    for item in (v.strip() for v in rest.split(",")):
        if name == "strategy":
            if item not in STRATEGIES:
                raise CompanionError(f"--sweep {text!r}: strategy must be one of "
                                     f"{', '.join(STRATEGIES)}, got {item!r}")
            values.append(item)
            continue
        try:
            values.append(float(item))
        except ValueError:
            raise CompanionError(f"--sweep {text!r}: {name}: expected a number, got {item!r}") from None
    if len(set(values)) != len(values):
        raise CompanionError(f"--sweep {text!r}: a value is repeated")
    return name, values


def make_batch(base: Scenario, kind: str | None, strategy: str | None,
               sweep: tuple[str, object] | None = None) -> Batch:
    """The batch for one row; a sweep value replaces that field of the scenario's avoidance."""
    strategy = strategy or base.avoidance.strategy
    if sweep is None:
        return Batch(base, kind, strategy)
    name, value = sweep
    if name == "strategy":
        return Batch(base, kind, value)
    try:
        avoidance = dataclasses.replace(base.avoidance, **{name: value})
        scenario = dataclasses.replace(base, avoidance=avoidance)
    except FieldError as exc:
        raise CompanionError(f"--sweep {name}={value}: {exc}") from None
    return Batch(scenario, kind, strategy)


# ------------------------------------------------------------------ the cluster
def require_dask():
    try:
        import distributed
    except ImportError as exc:
        raise DaskMissing("campaign needs Dask, which is not installed: "
                          f"pip install .[cluster]  (or: pip install 'dask[distributed]'); {exc}") from None
    return distributed


def local_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:               # not on Linux
        return os.cpu_count() or 1


@contextmanager
def open_client(workers: int | None = None, scheduler: str | None = None) -> Iterator:
    """A Dask Client: on an existing cluster at ``scheduler``, else on a LocalCluster started here
    (``workers`` processes, default one per core, one thread each, no dashboard) and closed on exit.
    """
    distributed = require_dask()
    # distributed installs its own INFO handler on import; follow the verbosity __main__ chose.
    logging.getLogger("distributed").setLevel(logging.getLogger().getEffectiveLevel())
    if scheduler is not None:
        try:
            client = distributed.Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as exc:
            raise CompanionError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        with client:
            yield client
        return
    # Processes, not threads: the simulation is pure Python and numpy on small arrays, so threads
    # would serialise on the GIL. The scheduler always serves HTTP (health, metrics); ":0" puts it,
    # and the dashboard if bokeh is installed, on a free port rather than 8787.
    # Workers forked from this process (where supported) start with companion, numpy and scipy
    # already imported: spawned ones spent about a second importing them again, which on a
    # 200-run campaign was a tenth of the work.
    import dask
    import multiprocessing
    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    with dask.config.set({"distributed.worker.multiprocessing-method": method}):
        with distributed.LocalCluster(n_workers=workers or local_cores(), threads_per_worker=1,
                                      processes=True, dashboard_address=":0",
                                      preload=["companion.tools.worker_lifetime"]) as cluster:
            with distributed.Client(cluster) as client:
                yield client


def worker_threads(client) -> int:
    """Slots for tasks on the cluster right now (at least 1, so planning never divides by 0)."""
    return max(1, sum(client.nthreads().values()))


def run_rows(client, batches: Sequence[Batch], first_seed: int, runs: int,
             on_done: Callable[[int], None] | None = None, values: Sequence | None = None) -> list[Row]:
    """Fly ``runs`` runs of every batch on the cluster; rows come back in order, runs in index order.

    All rows' chunks are submitted at once so the cluster stays busy across rows. ``on_done(n)``
    is called as each chunk of n runs completes (for a progress bar).
    """
    distributed = require_dask()
    size = runs_per_task(runs * len(batches), worker_threads(client))
    plan = chunks(first_seed, runs, size)
    futures = {}
    for row, batch in enumerate(batches):
        for index, (seed, count) in enumerate(plan):
            future = client.submit(fly_chunk, batch, seed, count, pure=False)
            futures[future] = (row, index)
    log.info("campaign: %d rows x %d runs in %d tasks of up to %d runs on %d workers",
             len(batches), runs, len(futures), size, worker_threads(client))
    parts: list[list] = [[None] * len(plan) for _ in batches]
    try:
        for future in distributed.as_completed(futures):
            row, index = futures[future]
            parts[row][index] = future.result()      # a worker's exception is re-raised here
            if on_done is not None:
                on_done(len(parts[row][index]))
    except BaseException:
        client.cancel(list(futures))                 # a shared cluster must not keep our work
        raise
    values = list(values) if values is not None else [None] * len(batches)
    return [Row(value, batch, [r for part in rows for r in part])
            for value, batch, rows in zip(values, batches, parts)]


# ------------------------------------------------------------------ fleet replay
FLIGHT_COLUMNS = ("file", "log_duration_s", "flight_time_s", "urgent_events",
                  "closest_estimated_approach_m", "max_position_sigma_m", "arrived", "landmarks",
                  "messages", "setpoints", "setpoints_mismatched", "damaged", "error", "notes")


def find_tlogs(patterns: Sequence[str]) -> list[Path]:
    """Every tlog named by ``patterns`` (a file, a folder searched recursively, or a glob), sorted."""
    found: set[Path] = set()
    for pattern in patterns:
        path = Path(pattern)
        if path.is_dir():
            found.update(p for p in path.rglob("*.tlog") if p.is_file())
        elif path.is_file():
            found.add(path)
        else:
            found.update(Path(p) for p in glob.glob(pattern, recursive=True) if Path(p).is_file())
    return sorted(found)


def flight_config_path(tlog: Path, default: str | Path) -> Path:
    """As ``companion replay`` chooses: FILE.config.yaml written beside the tlog, else ``default``."""
    from companion.daemon.replay import sidecar_config_path
    sidecar = sidecar_config_path(tlog)
    return sidecar if sidecar.exists() else Path(default)


def summarise_flight(tlog: str | Path, config_path: str | Path) -> dict:
    """Replay one tlog with ``companion replay``'s engine and reduce it to one table row.

    closest_estimated_approach_m: the smallest distance from the estimated track to a landmark
    of the final estimated map. max_position_sigma_m: the largest 1-sigma position uncertainty
    along the track (square root of the largest eigenvalue of the 2x2 position covariance).
    A file or sidecar config that cannot be read gives a row with ``error`` set, not a failure.
    """
    from companion.config.service import load_config
    from companion.tools.replay import comparison, replay_tlog
    row = dict.fromkeys(FLIGHT_COLUMNS)
    row["file"] = str(tlog)
    try:
        result = replay_tlog(tlog, load_config(config_path))
    except (CompanionError, OSError) as exc:
        row["error"] = str(exc)
        return row
    pipeline = result.pipeline
    track = np.array(pipeline.track, dtype=float).reshape(-1, 13)   # t_s, n, e, yaw, 3x3 cov
    landmarks = (pipeline.navigator.slam.landmarks() if pipeline.navigator is not None
                 else np.zeros((0, 2)))
    row.update(
        log_duration_s=(result.last_us - result.first_us) / 1e6 if result.messages else 0.0,
        flight_time_s=float(track[-1, 0] - track[0, 0]) if len(track) else None,
        urgent_events=sum(1 for r in pipeline.urgency if r.state == "urgent"),
        closest_estimated_approach_m=closest_approach_m(track[:, 1:3], landmarks),
        max_position_sigma_m=max_position_sigma_m(track[:, 4:].reshape(-1, 3, 3)),
        arrived=pipeline.arrival_t_s is not None, landmarks=len(landmarks),
        messages=result.messages, setpoints=len(result.setpoints),
        setpoints_mismatched=(comparison(result)["setpoints_mismatched"] if result.recorded_keys
                              else None),
        damaged=bool(result.stats.damaged), notes="; ".join(result.notes))
    return row


def closest_approach_m(track_ne: np.ndarray, landmarks_ne: np.ndarray) -> float | None:
    """Smallest distance between any track point (k, 2) and any landmark (m, 2); None if either
    is empty."""
    if not len(track_ne) or not len(landmarks_ne):
        return None
    gaps = np.hypot(*(track_ne[:, None, :] - landmarks_ne[None, :, :]).transpose(2, 0, 1))
    return float(gaps.min())


def max_position_sigma_m(pose_covs: np.ndarray) -> float | None:
    """Largest sqrt(eigenvalue) of the position block of the pose covariances (k, 3, 3)."""
    if not len(pose_covs):
        return None
    block = pose_covs[:, :2, :2]
    values = np.linalg.eigvalsh(0.5 * (block + block.transpose(0, 2, 1)))
    return float(np.sqrt(np.clip(values.max(), 0.0, None)))


def summarise_flights(entries: Sequence[tuple[str, str]]) -> list[dict]:
    """One Dask task: (tlog path, config path) pairs to rows, in order."""
    return [summarise_flight(tlog, config) for tlog, config in entries]


def replay_fleet(client, tlogs: Sequence[Path], default_config: str | Path,
                 on_done: Callable[[int], None] | None = None) -> list[dict]:
    """Per-flight rows for ``tlogs``, in the order given. Workers read the files themselves, so
    on a remote cluster the paths must be visible to them (a shared or identical filesystem)."""
    distributed = require_dask()
    entries = [(str(p.resolve()), str(flight_config_path(p, default_config).resolve()))
               for p in tlogs]
    size = runs_per_task(len(entries), worker_threads(client))
    futures = {client.submit(summarise_flights, entries[i:i + size], pure=False): i
               for i in range(0, len(entries), size)}
    rows: list[dict | None] = [None] * len(entries)
    try:
        for future in distributed.as_completed(futures):
            start = futures[future]
            part = future.result()
            rows[start:start + len(part)] = part
            if on_done is not None:
                on_done(len(part))
    except BaseException:
        client.cancel(list(futures))
        raise
    for row, tlog in zip(rows, tlogs):
        row["file"] = str(tlog)                    # as the user named it, not resolved
    return rows


def fleet_totals(rows: Sequence[dict]) -> dict:
    """The fleet at a glance: flights, failures, total urgent events, worst approach and sigma."""
    ok = [r for r in rows if r["error"] is None]
    approaches = [r["closest_estimated_approach_m"] for r in ok if r["closest_estimated_approach_m"] is not None]
    sigmas = [r["max_position_sigma_m"] for r in ok if r["max_position_sigma_m"] is not None]
    return {
        "flights": len(rows), "failed": len(rows) - len(ok),
        "damaged": sum(1 for r in ok if r["damaged"]),
        "log_hours": sum(r["log_duration_s"] for r in ok) / 3600.0,
        "urgent_events": sum(r["urgent_events"] for r in ok),
        "closest_estimated_approach_m": min(approaches) if approaches else None,
        "max_position_sigma_m": max(sigmas) if sigmas else None,
    }
