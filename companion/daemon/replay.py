"""A recorded tlog through the same Pipeline as the live daemon: the daemon's wiring fed from a
file instead of a link (``companion replay`` and the live view's replay both use it).

Inbound records (everything not sent by a companion component) go through codec.decode and
Pipeline.handle in file order, stamped with their own tlog time, exactly as the daemon fed them
live; so a tlog the daemon recorded replays to the same estimates and the same setpoints. What
the recorded companion sent (its SET_POSITION_TARGET_LOCAL_NED and ODOMETRY) is kept aside for
companion/tools/replay.py to compare with what the replay would send.

With ``depth`` (the flight's depth frames, ``companion replay --depth SOURCE``), the frames are
taken in as the lock-step service took them (companion/daemon/depth_feed.py, ``settle``): before
the vehicle's position of time t, every frame captured by then, in order, perceived here.
"""
from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

from companion.mavlink import codec
from companion.mavlink.tlog import TlogReader, TlogStats
from companion.config.service import CompanionConfig
from companion.onboard.pipeline import Pipeline


def sidecar_config_path(tlog_path: str | Path) -> Path:
    """Where the effective config of a recorded run is written (by companion run, beside its
    tlog) and read back for its replay: FILE.tlog -> FILE.config.yaml."""
    return Path(tlog_path).with_suffix(".config.yaml")


@dataclass
class ReplayResult:
    path: Path
    stats: TlogStats
    pipeline: Pipeline
    config: CompanionConfig
    messages: int = 0
    inbound: int = 0
    by_type: Counter = field(default_factory=Counter)
    first_us: int | None = None
    last_us: int | None = None
    wall_s: float = 0.0
    setpoints: list = field(default_factory=list)          # replayed VelocitySetpoint
    replayed_keys: list = field(default_factory=list)      # their wire values
    recorded_keys: list = field(default_factory=list)      # what the companion sent
    replayed_poses: dict = field(default_factory=dict)     # time_usec -> float32 (north, east)
    recorded_poses: list = field(default_factory=list)     # (time_usec, north, east)
    notes: list = field(default_factory=list)


def replay_tlog(path: str | Path, config: CompanionConfig,
                progress: Callable[[int], None] | None = None,
                on_inbound: Callable[[int, Pipeline], None] | None = None,
                depth: Iterator | None = None) -> ReplayResult:
    """Replay one tlog; never raises on a damaged file (see ``stats`` and ``notes``).
    ``on_inbound(t_us, pipeline)`` after each inbound message (the live view's replay).
    ``depth``: the flight's depth frames (SourcedFrames, in order; a source's error raises)."""
    reader = TlogReader(path, progress)
    pipeline = Pipeline(config, config.goal, record_track=True)
    result = ReplayResult(Path(path), reader.stats, pipeline, config)
    ours = config.link.component_id
    started = time.perf_counter()
    frames = _Frames(depth) if depth is not None else None
    for record in reader:
        msg = record.msg
        kind = codec.message_type(msg)
        result.messages += 1
        result.by_type[kind] += 1
        result.first_us = record.t_us if result.first_us is None else result.first_us
        result.last_us = record.t_us
        if codec.is_from_us(msg, ours):
            if kind == "SET_POSITION_TARGET_LOCAL_NED":
                result.recorded_keys.append(codec.setpoint_key(msg))
            elif kind == "ODOMETRY":
                result.recorded_poses.append(codec.odometry_key(msg))
            continue
        result.inbound += 1
        event = codec.decode(msg)
        if frames is not None and isinstance(event, codec.LocalPosition) and (
                pipeline.vehicle is None
                or (event.system_id, event.component_id) == pipeline.vehicle):
            _collect(result, frames.take_in(pipeline, event.t_s, record.t_us / 1e6))
        _collect(result, pipeline.handle(record.t_us / 1e6, event))
        if on_inbound is not None:
            on_inbound(record.t_us, pipeline)
    if len(result.recorded_keys) == len(result.replayed_keys) + 1 and result.last_us is not None:
        # the daemon's shutdown: SIGINT/SIGTERM while commanding sent one stop setpoint
        for output in pipeline.stop_setpoint(result.last_us / 1e6):
            if not isinstance(output, codec.VelocitySetpoint):
                continue                  # PX4's Hold request after it: no setpoint
            result.setpoints.append(output)
            result.replayed_keys.append(codec.setpoint_key_of(output))
    result.wall_s = time.perf_counter() - started
    _add_notes(result)
    return result


def _collect(result: ReplayResult, outputs) -> None:
    for output in outputs:
        if isinstance(output, codec.VelocitySetpoint):
            result.setpoints.append(output)
            result.replayed_keys.append(codec.setpoint_key_of(output))
        elif isinstance(output, codec.PoseEstimate):
            result.replayed_poses[int(round(output.t_s * 1e6))] = (
                codec.float32(output.north_m), codec.float32(output.east_m))


class _Frames:
    """The recorded frames, one looked ahead."""

    def __init__(self, frames: Iterator) -> None:
        self._frames = iter(frames)
        self._next = next(self._frames, None)

    def take_in(self, pipeline: Pipeline, t_s: float, t_link_s: float) -> list:
        """Every frame captured by ``t_s``: perceived, into the pipeline (its outputs)."""
        out: list = []
        while self._next is not None:
            sourced = self._next
            capture_s = pipeline.depth.capture_time_s(sourced.frame, sourced.host_time_s)
            if capture_s is not None and capture_s > t_s + 1e-6:
                break
            self._next = next(self._frames, None)
            job = pipeline.depth.job(sourced.frame, capture_s, final=True)
            if not isinstance(job, str):
                pipeline.depth.absorb(t_link_s, job, job.perceive(), out)
        return out


def _add_notes(result: ReplayResult) -> None:
    notes, p = result.notes, result.pipeline
    notes.extend(result.stats.notes)
    if result.stats.bytes_skipped:
        notes.append(f"{result.stats.bytes_skipped} corrupt bytes skipped in "
                     f"{result.stats.skipped_regions} place(s)")
    if result.stats.bad_packets:
        notes.append(f"{result.stats.bad_packets} packets unreadable (bad CRC or unknown id)")
    if result.messages and p.vehicle is None:
        notes.append("no autopilot heartbeat found (or not from the --sysid given): nothing replayed")
    if p.other_vehicles:
        notes.append(f"several vehicles: replayed system {p.vehicle[0] if p.vehicle else '?'}, "
                     f"ignored {sorted(p.other_vehicles)} (choose with --sysid)")
    if p.vehicle is not None and not (result.by_type["OBSTACLE_DISTANCE_3D"]
                                      + result.by_type["OBSTACLE_DISTANCE"]):
        notes.append("no obstacle messages: a pose-only track (odometry dead reckoning)")
    if p.vehicle is not None and p.navigator is None:
        notes.append("no LOCAL_POSITION_NED with ATTITUDE from the vehicle: no track")
    if result.config.goal is None:
        notes.append("no goal configured: estimates only, no guidance or setpoints")
    if not result.recorded_keys and not result.recorded_poses:
        notes.append("the tlog holds nothing a companion sent: no comparison")
