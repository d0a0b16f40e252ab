"""``companion run --lockstep``: the link clock is the vehicle's clock.

Against ``sitl-stub --lockstep`` the world waits for us, so wall time says nothing about the
vehicle: a heartbeat 3 wall seconds old may be 0.1 s old in vehicle time on a loaded machine, and
20 s old on an idle one. In lock-step every stamp the service uses (the pipeline's link time, the
tlog's record time, our heartbeat schedule) comes from this clock instead: the Unix time at start
plus the latest vehicle time (``time_boot_ms``/``time_usec``) seen in the stream. It only moves
when messages arrive, is monotonic (a vehicle reboot rebases it) and is the same number in
replay, which reads it back from the tlog.
"""
from __future__ import annotations

import dataclasses
import math
import time

from companion.mavlink import codec

REBOOT_BACKSTEP_S = 1.0


def lockstep_config(config):
    """The config for lock-step: one ODOMETRY per odometry sample (the stub's sign that we have
    caught up), so ``odometry_rate_hz`` is raised to the position stream's rate."""
    rate_hz = max(config.commanding.odometry_rate_hz, config.streams.local_position_rate_hz)
    return dataclasses.replace(config, commanding=dataclasses.replace(
        config.commanding, odometry_rate_hz=rate_hz))


class VehicleLinkClock:
    """Microseconds: Unix time at start + vehicle time, advanced by the messages themselves."""

    def __init__(self, heartbeat_period_s: float, base_unix_s: float | None = None) -> None:
        self._base_us = int((time.time() if base_unix_s is None else base_unix_s) * 1e6)
        self._offset_s = 0.0            # grows at each vehicle reboot, so the clock never steps back
        self._last_vehicle_s: float | None = None
        self._now_s = 0.0
        self._heartbeat_period_s = heartbeat_period_s
        self._next_heartbeat_s = 0.0

    @property
    def started(self) -> bool:
        """A message with a vehicle time has been seen."""
        return self._last_vehicle_s is not None

    def observe(self, event) -> int:
        """Advance by the autopilot's time in the event (ATTITUDE, LOCAL_POSITION_NED), as the
        pipeline tracks the vehicle clock; returns the stamp for the event."""
        if isinstance(event, (codec.Attitude, codec.LocalPosition)) and math.isfinite(event.t_s):
            t_s, last = event.t_s, self._last_vehicle_s
            if last is not None and t_s < last - REBOOT_BACKSTEP_S:
                self._offset_s = self._now_s - t_s     # reboot: carry on from where we were
                self._last_vehicle_s = t_s
            else:
                self._last_vehicle_s = t_s if last is None else max(last, t_s)
            self._now_s = max(self._now_s, self._offset_s + self._last_vehicle_s)
        return self.now_us()

    def now_us(self) -> int:
        return self._base_us + int(round(self._now_s * 1e6))

    def heartbeat_due(self) -> bool:
        """Our heartbeat is due on this clock (then it is scheduled one period later)."""
        if not self.started or self._now_s + 1e-9 < self._next_heartbeat_s:
            return False
        self._next_heartbeat_s += self._heartbeat_period_s
        if self._next_heartbeat_s <= self._now_s:
            self._next_heartbeat_s = self._now_s + self._heartbeat_period_s
        return True
