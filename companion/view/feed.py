"""The view feed: what the companion knows, as one compact JSON datagram, several times a second.

The live service (``companion run --view-feed HOST:PORT``) and the view's own tlog replay build
it with :func:`feed_state` from the same Pipeline, so ``companion view`` cannot tell live from
replay. One datagram is a whole picture (latest pose, map, movers, goal, decision, state) plus
the estimated path since the previous datagram: a lost datagram costs a short gap in the drawn
path, never a wrong map. UDP, fire and forget: the service never waits for a view, and runs the
same whether one listens or not.

Format (``"feed": FEED_VERSION``): metres north/east of the EKF origin, radians, vehicle seconds.
"""
from __future__ import annotations

import asyncio
import json
import logging
import math

import numpy as np

from companion.core.avoidance.guidance import inflated_radius
from companion.core.avoidance.union import blocking
from companion.errors import ConfigError

log = logging.getLogger(__name__)

FEED_VERSION = "companion-view/1"
FEED_RATE_HZ = 10.0              # the service's sending rate (the page wants >= 5 Hz)
SECTORS = 72                     # blocked headings in 5 degree sectors
PATH_STEP_S = 0.2                # the path in the feed: one pose per 0.2 s of vehicle time
MAX_PATH_POINTS = 400            # per datagram (a view that joins late gets the rest from now on)
MAX_DATAGRAM_BYTES = 60_000      # under UDP's 65,507: a bigger map is cut to the nearest landmarks


def parse_address(text: str, what: str) -> tuple[str, int]:
    """'HOST:PORT' or 'udp:HOST:PORT' -> (host, port); a ConfigError names ``what``."""
    body = text[4:] if text.startswith("udp:") else text
    host, _, port = body.rpartition(":")
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not host or not 0 <= number <= 65535:
        raise ConfigError(f"{what}: expected HOST:PORT (udp:HOST:PORT), got {text!r}")
    return host, number


class PathCursor:
    """Which rows of the pipeline's track the feed has already carried."""

    def __init__(self) -> None:
        self.last_t_s: float | None = None       # the newest row seen
        self.kept_t_s: float | None = None       # the newest row sent (the step counts from it)

    def take(self, track) -> list[list[float]]:
        """New rows (t_s, north_m, east_m, ...) of ``track``, one per PATH_STEP_S, oldest first."""
        if track and self.last_t_s is not None and track[-1][0] < self.last_t_s - 1.0:
            self.last_t_s = self.kept_t_s = None  # the vehicle's clock restarted (a reboot)
        fresh = []
        for row in reversed(track):            # newest first: stop at what was sent
            if self.last_t_s is not None and row[0] <= self.last_t_s:
                break
            if fresh and row[0] > fresh[-1][0]:
                break                          # rows from before the clock restarted
            fresh.append(row)
            if len(fresh) >= MAX_PATH_POINTS * 50:
                break
        points = []
        for row in reversed(fresh):
            if self.kept_t_s is None or row[0] - self.kept_t_s >= PATH_STEP_S - 1e-6:
                points.append([round(row[1], 2), round(row[2], 2)])
                self.kept_t_s = row[0]
        if fresh:
            self.last_t_s = fresh[0][0]
        return points[-MAX_PATH_POINTS:]


def _cov2(cov) -> list[float]:
    """A 2x2 covariance as [var_n, cov_ne, var_e] (m^2), rounded for the wire."""
    return [float(f"{cov[0][0]:.4g}"), float(f"{cov[0][1]:.4g}"), float(f"{cov[1][1]:.4g}")]


def blocked_sectors(nav, cruise_mps: float) -> list[int]:
    """Indices k of the SECTORS headings (k * 360/SECTORS deg, from north, clockwise) that the
    union rule blocks now, at cruise speed, for the mapped obstacles and movers."""
    obstacles, velocities, rel_covs, _ = nav.obstacles()
    if len(obstacles) == 0:
        return []
    params = nav.params
    radii = np.full(len(obstacles), params.safety_distance_m) if rel_covs is None else \
        np.array([inflated_radius(params.safety_distance_m, c, params.inflation_sigmas)
                  for c in rel_covs])
    goal_m = float(np.hypot(*(nav.goal - nav.slam.pose[:2])))
    headings = np.arange(SECTORS) * (2.0 * math.pi / SECTORS)
    lookahead_s = nav.union.lookahead_s
    blocks = blocking(headings, nav.slam.pose[:2], obstacles, radii, params.eta,
                      min(cruise_mps * lookahead_s, goal_m), cruise_mps, velocities, lookahead_s)
    return np.flatnonzero(blocks.any(axis=1)).tolist()


def feed_state(pipeline, seq: int, cursor: PathCursor) -> dict:
    """One datagram's content from a Pipeline (see the module docstring)."""
    nav = pipeline.navigator
    config = pipeline.config
    decision = pipeline.last_command
    phase = pipeline.phase.decide(pipeline.latest_t_s) if pipeline.latest_t_s is not None \
        else None
    state = {
        "feed": FEED_VERSION, "seq": seq, "t_s": pipeline.latest_t_s,
        "vehicle": list(pipeline.vehicle) if pipeline.vehicle else None,
        "armed": pipeline.armed,
        "guided": pipeline.identity.steering,       # GUIDED (OFFBOARD on PX4)
        "phase": phase.phase if phase is not None else None,
        "arrived": pipeline.arrival_t_s is not None,
        "safe_action": pipeline.safe_reason,
        "goal_ne_m": list(pipeline.goal_ne) if pipeline.goal_ne is not None else None,
        "goal_radius_m": pipeline.goal.radius_m if pipeline.goal is not None else None,
        "safety_distance_m": config.safety_distance_m,
        "estimator": None, "radius_2sigma_m": None, "pose": None, "path_ne_m": [],
        "landmarks": [], "movers": [], "command": None, "blocked": [], "sectors": SECTORS,
        "setpoints": pipeline.setpoints,
    }
    if nav is None:
        return state
    if nav.health is not None:
        state["estimator"] = nav.health.state
        state["radius_2sigma_m"] = round(nav.health.radius_2sigma_m, 2)
    pose, cov = nav.slam.pose, nav.slam.pose_cov
    if np.all(np.isfinite(pose)) and np.all(np.isfinite(cov)):
        state["pose"] = {"north_m": round(float(pose[0]), 3), "east_m": round(float(pose[1]), 3),
                         "yaw_rad": round(float(pose[2]), 4), "cov_m2": _cov2(cov),
                         "sigma_yaw_rad": round(math.sqrt(max(cov[2][2], 0.0)), 5)}
    state["path_ne_m"] = cursor.take(pipeline.track) if pipeline.record_track else (
        [[state["pose"]["north_m"], state["pose"]["east_m"]]] if state["pose"] else [])
    state["landmarks"] = [
        {"id": oid if oid is None or oid >= 0 else None, "north_m": round(float(m[0]), 3),
         "east_m": round(float(m[1]), 3), "cov_m2": _cov2(c)}
        for oid, m, c in zip(nav.slam.landmark_ids(), nav.slam.landmarks(),
                             nav.slam.landmark_covs())]
    state["movers"] = [
        {"track_id": m.track_id, "id": m.obstacle_id,
         "north_m": round(float(m.position_ne_m[0]), 3),
         "east_m": round(float(m.position_ne_m[1]), 3),
         "vel_north_mps": round(float(m.velocity_ne_mps[0]), 3),
         "vel_east_mps": round(float(m.velocity_ne_mps[1]), 3), "cov_m2": _cov2(m.position_cov)}
        for m in nav.movers.states(nav.clock_s) if np.all(np.isfinite(m.position_ne_m))]
    if decision is not None:
        state["command"] = {"t_s": decision[0], "heading_rad": round(decision[1].heading_rad, 4),
                            "speed_mps": round(decision[1].speed_mps, 3),
                            "mode": decision[1].mode}
    if np.all(np.isfinite(pose)):
        state["blocked"] = blocked_sectors(nav, config.commanding.cruise_speed_mps)
    return state


def encode(state: dict) -> bytes:
    """JSON bytes that fit one datagram: the farthest landmarks are left out if need be."""
    data = json.dumps(state, separators=(",", ":"), allow_nan=False).encode()
    if len(data) <= MAX_DATAGRAM_BYTES or not state["landmarks"]:
        return data
    pose = state["pose"] or {"north_m": 0.0, "east_m": 0.0}
    by_distance = sorted(state["landmarks"], key=lambda m: math.hypot(
        m["north_m"] - pose["north_m"], m["east_m"] - pose["east_m"]))
    keep = max(1, int(len(by_distance) * MAX_DATAGRAM_BYTES / len(data) * 0.9))
    trimmed = dict(state, landmarks=by_distance[:keep], landmarks_left_out=len(by_distance) - keep)
    return json.dumps(trimmed, separators=(",", ":"), allow_nan=False).encode()


def decode(data: bytes) -> dict:
    """A datagram -> its state; ValueError for anything that is not a feed datagram."""
    try:
        state = json.loads(data, parse_constant=_refuse_constant)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"not JSON: {exc}") from None
    if not isinstance(state, dict) or state.get("feed") != FEED_VERSION:
        raise ValueError(f"not a {FEED_VERSION} datagram")
    for key, kind in (("landmarks", list), ("movers", list), ("path_ne_m", list),
                      ("blocked", list), ("seq", int)):
        if not isinstance(state.get(key), kind):
            raise ValueError(f"{key}: expected a {kind.__name__}")
    return state


def _refuse_constant(name: str):
    raise ValueError(f"non-finite number {name}")


class _Quiet(asyncio.DatagramProtocol):
    """No view listening makes loopback answer 'port unreachable': expected, not an error."""

    def __init__(self) -> None:
        self.refused = 0

    def error_received(self, exc: Exception) -> None:
        self.refused += 1


async def publish(pipeline, address: tuple[str, int], rate_hz: float = FEED_RATE_HZ) -> None:
    """Send :func:`feed_state` to ``address`` every 1/rate_hz s of wall time, until cancelled."""
    loop = asyncio.get_running_loop()
    transport, protocol = await loop.create_datagram_endpoint(_Quiet, remote_addr=address)
    log.info("view feed to udp:%s:%d at %.0f Hz", *address, rate_hz)
    cursor, seq = PathCursor(), 0

    def send() -> bool:
        """One datagram; False when the feed must stop."""
        nonlocal seq
        seq += 1
        try:
            data = encode(feed_state(pipeline, seq, cursor))
        except ValueError as exc:          # a non-finite value (a diverging estimate)
            log.warning("view feed: datagram %d not sent: %s", seq, exc)
            return True
        except Exception:
            # The view is for people watching; avoidance must not stop for it. Say so once,
            # loudly, and stop feeding (the service goes on).
            log.exception("view feed stopped by a fault in building its state")
            return False
        transport.sendto(data)
        return True

    healthy = True
    try:
        while healthy:
            await asyncio.sleep(1.0 / rate_hz)
            healthy = send()
    finally:
        # The last picture on shutdown: a lock-step flight can end (arrival, SIGTERM) within
        # one feed period, and the view would never see the arrival.
        if healthy:
            send()
        transport.close()
