"""``companion run --depth SOURCE``: the service's own depth frames, read and perceived off the
event loop, taken into the pipeline on it (companion/onboard/depth_intake.py).

- A reader thread iterates the source (companion/depth/open.py: blocking reads and decoding)
  and hands each frame to the loop through a bounded slot (``FrameSlot``).
- Live: a task takes the newest frames of each camera (at most LIVE_PER_CAMERA wait; a newer
  one drops the oldest, counted: the stub sends its 15 Hz frames on 10 Hz steps, two at once
  every other step, and with one place the first of the two was dropped a third of the time
  the task was busy), waits for the ATTITUDE of its capture if it has not come, and runs the perception
  (core/perception/depth_perception.py, numpy: tens of ms) in a one-thread executor; the loop
  keeps handling MAVLink meanwhile. The observations go to the estimator on the loop.
- Lock-step (``settle``): the stub sends a step's frames before the step's messages, on another
  socket; before the service handles the position of time t, it waits (bounded) for every frame
  captured at or before t (the stub's frame k is captured at k / ``perception.depth.rate_hz``,
  docs/depth.md) and takes them in, in order. No frame is dropped: the flight is the same
  whatever the load.
- Errors: a source that cannot be opened (no camera, a bag without a depth stream, a wrong
  encoding, a missing extra) stops the service with the source's message (DepthSourceError);
  a source that fails or ends after frames came is logged, and the camera goes stale: the
  configured safe action follows (failsafe.obstacle_timeout_s).
"""
from __future__ import annotations

import asyncio
import logging
import math
import threading
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor

from companion.config.depth_perception import parse_source
from companion.depth.frames import DepthSourceError, SourcedFrame
from companion.errors import CompanionError

log = logging.getLogger(__name__)

LIVE_PER_CAMERA = 2         # live: frames of one camera waiting; a newer one drops the oldest
LOCKSTEP_QUEUE = 64          # frames held in lock-step (a step brings one or two per camera)
LOCKSTEP_WAIT_S = 3.0        # wall seconds a lock-step sample waits for its frames (the stub's)
ATTITUDE_WAIT_S = 0.5        # live: a frame waits this long for the ATTITUDE of its capture
LATENCY_KEPT = 20_000        # frames' read -> absorbed latencies kept for the report


class FrameSlot:
    """Frames from the reader thread to the loop (all methods on the loop's thread)."""

    def __init__(self, keep_all: bool) -> None:
        self.keep_all = keep_all
        self.frames: deque[tuple[SourcedFrame, float]] = deque()
        self.dropped = 0
        self.received = 0
        self.last_key: tuple[int, int] | None = None    # (frame number, camera id) last read
        self.ended = False
        self.error: BaseException | None = None
        self.changed = asyncio.Event()

    def put(self, sourced: SourcedFrame, read_s: float) -> None:
        frame = sourced.frame
        if self.keep_all:
            if len(self.frames) >= LOCKSTEP_QUEUE:
                self.frames.popleft()
                self.dropped += 1
        else:       # live: the newest of each camera win
            same = [i for i, (old, _) in enumerate(self.frames)
                    if old.frame.camera_id == frame.camera_id]
            if len(same) >= LIVE_PER_CAMERA:
                del self.frames[same[0]]
                self.dropped += 1
        self.frames.append((sourced, read_s))
        self.received += 1
        self.last_key = (frame.frame_number, frame.camera_id)
        self.changed.set()

    def end(self, error: BaseException | None = None) -> None:
        self.ended, self.error = True, error
        self.changed.set()

    def take(self) -> list[tuple[SourcedFrame, float]]:
        taken = list(self.frames)
        self.frames.clear()
        self.changed.clear()
        return taken


class DepthFeed:
    """One depth source for one service: the reader thread, the slot, the perception."""

    def __init__(self, spec: str, pipeline, lockstep: bool, dispatch, now_s) -> None:
        self.spec = spec
        self.source = parse_source(spec)
        self.pipeline = pipeline
        self.lockstep = lockstep
        self._dispatch = dispatch          # async: one pipeline output out
        self._now_s = now_s                # the service's time (link or vehicle clock)
        self.slot = FrameSlot(keep_all=lockstep)
        self.attitude_seen = asyncio.Event()
        self.latencies_s: deque[float] = deque(maxlen=LATENCY_KEPT)
        self.perceive_s: deque[float] = deque(maxlen=LATENCY_KEPT)
        # (capture s on the vehicle's clock, Unix s when absorbed, observations, Unix s when
        # read): benchmarks/depth_service.py's capture -> setpoint, with the tlog's setpoints
        self.absorbed: deque[tuple[float, float, int, float]] = deque(maxlen=LATENCY_KEPT)
        self.wait_timeouts = 0
        self._stop = threading.Event()
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="depth-perceive")
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------ the reader thread
    def start(self) -> None:
        loop = asyncio.get_running_loop()
        self._thread = threading.Thread(target=self._read, args=(loop,), name="depth-reader",
                                        daemon=True)     # a blocked read must not hold the exit
        self._thread.start()

    def _read(self, loop: asyncio.AbstractEventLoop) -> None:
        from companion.depth.open import open_depth_source
        error: BaseException | None = None
        try:
            frames = open_depth_source(self.source)
            try:
                for sourced in frames:
                    if self._stop.is_set():
                        break
                    loop.call_soon_threadsafe(self.slot.put, sourced, time.monotonic())
            finally:
                frames.close()
        except (CompanionError, OSError, ValueError) as exc:
            error = exc
        try:
            loop.call_soon_threadsafe(self.slot.end, error)
        except RuntimeError:
            pass                           # the loop is closed: the service has stopped

    def close(self) -> None:
        self._stop.set()
        self._executor.shutdown(wait=False, cancel_futures=True)

    # ------------------------------------------------------------ live
    async def run(self) -> None:
        """Live: perceive frames as they come. Lock-step: only watch the source (``settle``
        takes the frames). Raises DepthSourceError if the source fails before any frame."""
        self.start()
        while True:
            await self.slot.changed.wait()
            if self.slot.ended and (self.lockstep or not self.slot.frames):
                self._on_end()                   # (lock-step: settle takes what is left)
                return
            if self.lockstep:
                self.slot.changed.clear()
                continue
            for sourced, read_s in self.slot.take():
                await self._take_in(sourced, read_s, final=False)

    def _on_end(self) -> None:
        error = self.slot.error
        if error is not None and self.slot.received == 0:
            raise error if isinstance(error, DepthSourceError) else \
                DepthSourceError(f"depth source {self.spec}: {error}")
        if error is not None:
            log.error("depth source %s failed after %d frames: %s; the camera goes stale "
                      "(failsafe)", self.spec, self.slot.received, error)
        else:
            log.warning("depth source %s ended after %d frames", self.spec, self.slot.received)

    async def _take_in(self, sourced: SourcedFrame, read_s: float, final: bool) -> None:
        depth = self.pipeline.depth
        frame = sourced.frame
        t_capture_s = depth.capture_time_s(frame, sourced.host_time_s)
        job = depth.job(frame, t_capture_s, final)
        if job == "wait":
            try:
                async with asyncio.timeout(ATTITUDE_WAIT_S):
                    while (job := depth.job(frame, t_capture_s)) == "wait":
                        self.attitude_seen.clear()
                        await self.attitude_seen.wait()
            except TimeoutError:
                job = depth.job(frame, t_capture_s, final=True)
        if isinstance(job, str):
            return
        started_s = time.monotonic()
        percept = await asyncio.get_running_loop().run_in_executor(self._executor, job.perceive)
        self.perceive_s.append(time.monotonic() - started_s)
        out: list = []
        depth.absorb(self._now_s(), job, percept, out)
        since_read_s = time.monotonic() - read_s     # in the estimator, decided, not yet sent
        self.latencies_s.append(since_read_s)
        now_unix_s = time.time()
        self.absorbed.append((job.t_capture_s, now_unix_s, len(percept.observations),
                              now_unix_s - since_read_s))
        for output in out:
            await self._dispatch(output)

    # ------------------------------------------------------------ lock-step
    async def settle(self, t_s: float) -> None:
        """Before the position of time ``t_s``: every frame captured by then, taken in."""
        if self.source.kind == "stub" and self.slot.error is None:
            due = (math.floor(t_s * self.pipeline.config.perception.depth.rate_hz + 1e-6),
                   len(self.pipeline.config.perception.depth.mounts()) - 1)
            try:
                async with asyncio.timeout(LOCKSTEP_WAIT_S):
                    while not self.slot.ended and (self.slot.last_key is None
                                                   or self.slot.last_key < due):
                        self.slot.changed.clear()
                        await self.slot.changed.wait()
            except TimeoutError:
                self.wait_timeouts += 1
                log.warning("lock-step: the depth frames of %.3f s did not come within %.0f s "
                            "(%d times)", t_s, LOCKSTEP_WAIT_S, self.wait_timeouts)
        while self.slot.frames:
            sourced, read_s = self.slot.frames[0]
            if sourced.host_time_s is None and sourced.frame.time_boot_ms / 1000.0 > t_s + 1e-6:
                break                            # a later step's frame: its position first
            self.slot.frames.popleft()
            await self._take_in(sourced, read_s, final=True)

    def snapshot(self) -> dict:
        """The report's ``depth_feed``: frames read, dropped, waits timed out, the latencies."""
        def pct(values, q):
            if not values:
                return None
            ordered = sorted(values)
            return round(1000.0 * ordered[min(len(ordered) - 1, int(q * len(ordered)))], 3)
        return {"depth_feed": {
            "source": self.spec, "received": self.slot.received, "dropped": self.slot.dropped,
            "lockstep_wait_timeouts": self.wait_timeouts,
            "read_to_absorbed_ms": {"p50": pct(self.latencies_s, 0.5),
                                    "p99": pct(self.latencies_s, 0.99),
                                    "n": len(self.latencies_s)},
            "perceive_ms": {"p50": pct(self.perceive_s, 0.5), "p99": pct(self.perceive_s, 0.99)},
            "absorbed": [list(row) for row in self.absorbed]}}
