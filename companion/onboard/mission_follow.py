"""Following the autopilot's mission: when to download it, which waypoint is the goal, when to
download it again. Pure: returns what to send (mission requests, notices); time passed in.

- The download starts when the vehicle is found, and again when the mission changed:
  MISSION_CURRENT (ArduCopter 4.6 streams it with ``total``, items without home, 0 with no
  mission, and ``mission_state``; ``mission_id`` where the autopilot fills it) says a new
  ``total`` or a new non-zero ``mission_id``; or the vehicle accepted another client's upload
  (its MISSION_ACK ACCEPTED to that client, heard behind a router: companion/onboard/mission_traffic.py),
  which catches a re-upload of the same length without ``mission_id``; or ``recheck_s`` (off by
  default) passed since the last download: on a link of its own the companion hears nothing of
  a ground station's upload of the same length.
- Never a download while another client's transfer is in progress (the vehicle's MISSION_REQUEST
  to an uploader, MISSION_COUNT or items to a downloader): ArduCopter refuses downloads during an
  upload, and a listing ground station may take our items for its own. Ours is dropped when an
  upload starts and begun again once the vehicle acknowledged it. A refused download (DENIED:
  an upload we could not hear) is tried again after 1, 2, 4, 8, 8 ... s.
- MISSION_ITEM_REACHED comes from ArduCopter only in AUTO, as its own mission progresses: logged,
  not used (the companion flies in GUIDED).
- Waypoints are flown in order. A global one becomes metres with the EKF origin
  (companion/onboard/goal.py), and waits for it. Reaching one (the navigator's arrival, while commanding)
  is announced; its hold time (NAV_WAYPOINT param1, seconds, as ArduCopter's loiter at a
  waypoint) is waited out there, on vehicle time, before the next; after the last one the
  vehicle holds there ("mission complete"). Waypoint altitudes are not flown: the companion
  guides in 2D and holds the altitude at which commanding began (docs/missions.md).
"""
from __future__ import annotations

import logging
from dataclasses import asdict

from companion.mavlink import codec
from companion.mavlink import mission_codec as mc
from companion.onboard.goal import goal_north_east
from companion.onboard.mission import DownloadParams, MissionDownload, MissionPlan, Waypoint, build_plan
from companion.onboard.mission_traffic import TransferWatch

log = logging.getLogger(__name__)
RETRY_FAILED_AFTER_S = 5.0          # a download that went unanswered is tried again this much later
RETRY_REFUSED_S = (1.0, 2.0, 4.0, 8.0)   # after the 1st, 2nd, ... refusal in a row (then the last)


class MissionFollower:
    def __init__(self, own_component: int, default_radius_m: float,
                 params: DownloadParams = DownloadParams(),
                 recheck_s: float | None = None) -> None:
        self.own_component = own_component
        self.default_radius_m = default_radius_m
        self.home_seq: int | None = 0     # ArduPilot's home item; None on PX4 (identity.py sets it)
        self.params = params
        self.vehicle: tuple[int, int] | None = None
        self.download: MissionDownload | None = None
        self.plan: MissionPlan | None = None
        self.index = 0                              # the waypoint flown to
        self.reached: list[int] = []                # seq of each waypoint reached, in order
        self.downloads = 0
        self._signature: tuple[int, int] | None = None
        self._failed_t_s: float | None = None
        self._reference: codec.GeoReference | None = None
        self.recheck_s = recheck_s
        self.traffic = TransferWatch(own_component)
        self.refusals = 0                           # in a row
        self.deferred = 0                           # downloads put off for another's transfer
        self._wanted: str | None = None             # a download waits for the vehicle to be free
        self._retry_t_s: float | None = None
        self._last_download_t_s: float | None = None
        self._hold_until_s: float | None = None

    # ------------------------------------------------------------ downloads
    def on_vehicle(self, t_s: float, vehicle: tuple[int, int]) -> list:
        self.vehicle = vehicle
        return self._start(t_s, "vehicle found")

    def _start(self, t_s: float, why: str) -> list:
        """Download now, or as soon as the vehicle is free of another client's transfer."""
        if self.vehicle is None:
            return []
        busy = self.traffic.busy(t_s)
        if busy is not None:
            if self._wanted is None:
                self.deferred += 1
                log.info("mission: download (%s) waits: %s by %d:%d in progress", why, busy.kind,
                         *busy.peer)
            self._wanted = why
            return []
        log.info("mission: downloading (%s)", why)
        self._wanted, self._retry_t_s = None, None
        self.download = MissionDownload(self.vehicle, self.own_component, self.params)
        self._failed_t_s = None
        return self.download.start(t_s)

    def on_event(self, t_s: float, event) -> list:
        out: list = []
        if isinstance(event, mc.MissionCurrent):
            return self._on_current(t_s, event)
        if isinstance(event, mc.MissionItemReached):
            log.info("autopilot reports mission item %d reached (its own mission)", event.seq)
            return out
        if self.vehicle is not None and \
                (event.system_id, event.component_id) == self.vehicle:
            seen = self.traffic.on_event(t_s, event)
            if seen == "uploaded":
                peer = f"{event.target_system}:{event.target_component}"
                log.info("mission: the vehicle accepted an upload from %s", peer)
                out.append(codec.Notice(codec.SEVERITY_INFO,
                                        "companion: mission uploaded, re-reading"))
                self.download = None            # whatever it was, it read the old mission
                out.extend(self._start(t_s, f"uploaded by {peer}"))
                return out
            busy = self.traffic.busy(t_s)
            if busy is not None and busy.kind == "upload" and self.download is not None \
                    and self.download.active:
                # ours would be refused (DENIED) and read a mission being replaced
                log.info("mission: download dropped: upload by %d:%d in progress", *busy.peer)
                self.download, self._wanted = None, "after an upload"
                self.deferred += 1
                return out
        if self.download is None:
            return out
        out.extend(self.download.on_event(t_s, event))
        self._after_download_step(t_s, out)
        return out

    def tick(self, t_s: float) -> list:
        out: list = []
        if self.download is not None:
            out.extend(self.download.tick(t_s))
            self._after_download_step(t_s, out)
        if self._failed_t_s is not None and self._retry_t_s is not None \
                and t_s >= self._retry_t_s:
            out.extend(self._start(t_s, "after a failed download"))
        elif self._wanted is not None and self.download is None:
            out.extend(self._start(t_s, self._wanted))
        elif self.recheck_s is not None and self.download is None and self._wanted is None \
                and self._failed_t_s is None and self._last_download_t_s is not None \
                and t_s - self._last_download_t_s >= self.recheck_s:
            out.extend(self._start(t_s, "recheck"))
        return out

    def _on_current(self, t_s: float, current: mc.MissionCurrent) -> list:
        signature = (current.total, current.mission_id)
        previous, self._signature = self._signature, signature
        if previous is None or previous == signature:
            return []
        log.info("mission changed on the autopilot (total %d -> %d, id %d -> %d)",
                 previous[0], signature[0], previous[1], signature[1])
        if self.download is not None and self.download.active:
            # one under way (the upload's ACK started it, or a recheck): its count is checked
            # against this total when it is done, rather than begun again for every change
            return []
        return [codec.Notice(codec.SEVERITY_INFO, "companion: mission changed, re-reading"),
                *self._start(t_s, "mission changed")]

    def _after_download_step(self, t_s: float, out: list) -> None:
        dl = self.download
        if dl.state == "failed":
            refused = dl.failure.startswith("autopilot refused")
            self.refusals = self.refusals + 1 if refused else 0
            delay = RETRY_REFUSED_S[min(self.refusals, len(RETRY_REFUSED_S)) - 1] if refused \
                else RETRY_FAILED_AFTER_S
            log.warning("mission download failed: %s (%d resends): again in %.0f s", dl.failure,
                        dl.resends, delay)
            if self.refusals <= 1:
                out.append(codec.Notice(codec.SEVERITY_WARNING,
                                        f"companion: mission download failed: {dl.failure}"))
            self.download, self._failed_t_s, self._retry_t_s = None, t_s, t_s + delay
        elif dl.state == "done":
            self.download = None
            self.downloads += 1
            self.refusals = 0
            self._last_download_t_s = t_s
            self._adopt(build_plan(dl.items, self.default_radius_m, self.home_seq), out)
            total = self._signature[0] if self._signature is not None else None
            read = len(dl.items) - (1 if self.home_seq is not None else 0)
            if total not in (None, 0, 65535) and total != read:
                # MISSION_CURRENT says another length: the mission changed under the download
                out.extend(self._start(t_s, f"{read} items read, vehicle says {total}"))

    def _adopt(self, plan: MissionPlan, out: list) -> None:
        if self.plan is not None and plan.waypoints == self.plan.waypoints:
            return                      # the same waypoints: keep the progress
        self.plan, self.index, self.reached = plan, 0, []
        self._hold_until_s = None
        for reason in plan.skipped:
            log.warning("mission item %s", reason)
            out.append(codec.Notice(codec.SEVERITY_WARNING, f"companion: skip {reason}"))
        log.info("mission: %d waypoints (%d items skipped)", len(plan.waypoints),
                 len(plan.skipped))
        out.append(codec.Notice(codec.SEVERITY_INFO,
                                f"companion: mission of {len(plan.waypoints)} waypoints"))

    # ------------------------------------------------------------ the goal
    @property
    def needs_geo_reference(self) -> bool:
        return (self.plan is not None and any(w.is_geographic for w in self.plan.waypoints)
                and (self._reference is None or self._reference.kind != "origin"))

    def on_geo_reference(self, ref: codec.GeoReference) -> None:
        if self._reference is None or ref.kind == "origin":
            self._reference = ref

    @property
    def current(self) -> Waypoint | None:
        if self.plan is None or self.index >= len(self.plan.waypoints):
            return None
        return self.plan.waypoints[self.index]

    @property
    def complete(self) -> bool:
        return self.plan is not None and bool(self.plan.waypoints) \
            and self.index >= len(self.plan.waypoints)

    def goal(self) -> tuple[float, float, float] | None:
        """(north_m, east_m, radius_m) to fly to now, or None (no mission, no reference yet).
        After the last waypoint: the last one (hold there)."""
        if self.plan is None or not self.plan.waypoints:
            return None
        wp = self.plan.waypoints[min(self.index, len(self.plan.waypoints) - 1)]
        if not wp.is_geographic:
            return wp.north_m, wp.east_m, wp.radius_m
        ref = self._reference
        if ref is None:
            return None
        try:
            north, east = goal_north_east(wp.lat_deg, wp.lon_deg, ref.lat_deg, ref.lon_deg,
                                          ref.north_m, ref.east_m)
        except ValueError as exc:
            log.error("mission waypoint %d: %s", wp.seq, exc)
            return None
        return north, east, wp.radius_m

    def on_arrived(self, t_s: float) -> list:
        """The navigator is at the current waypoint (called on every decision there): announce
        it, wait out its hold time (vehicle time, from the first arrival), go on to the next."""
        wp = self.current
        if wp is None:
            return []
        if wp.hold_s > 0.0:
            if self._hold_until_s is None:
                self._hold_until_s = t_s + wp.hold_s
                log.info("waypoint %d: holding %.1f s", wp.seq, wp.hold_s)
                return [codec.Notice(codec.SEVERITY_INFO,
                                     f"companion: waypoint {wp.seq}, hold {wp.hold_s:.0f} s")]
            if t_s < self._hold_until_s:
                return []
        self._hold_until_s = None
        self.reached.append(wp.seq)
        self.index += 1
        log.info("waypoint %d reached at %.1f s", wp.seq, t_s)
        out = [codec.Notice(codec.SEVERITY_NOTICE, f"companion: waypoint {wp.seq} reached")]
        if self.complete:
            out.append(codec.Notice(codec.SEVERITY_NOTICE, "companion: mission complete"))
        return out

    def summary(self) -> dict:
        """For the report: the plan, what was skipped, which waypoints were reached."""
        plan = self.plan
        return {"downloads": self.downloads,
                "waypoints": [asdict(w) for w in plan.waypoints] if plan else [],
                "skipped": list(plan.skipped) if plan else [],
                "reached": list(self.reached), "complete": self.complete,
                "deferred": self.deferred, "uploads_seen": self.traffic.uploads_seen}
