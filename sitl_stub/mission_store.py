"""The vehicle's stored mission, as ArduCopter keeps and serves it (MAVLink mission protocol,
vehicle side). Pure: messages in, (replies) out, simulated time passed in.

ArduCopter 4.6 facts this follows (libraries/GCS_MAVLink/MissionItemProtocol.cpp, and observed
with the SITL binary of ../shared/ardupilot):
- Item 0 is home (AP_Mission writes home as command 0 once home is set): a mission of n
  waypoints is n + 1 items; MISSION_COUNT says so, MISSION_CURRENT.total says n (home excluded).
- Upload: MISSION_COUNT -> MISSION_REQUEST (not _INT: 4.6 asks with MISSION_REQUEST) seq 0, 1, ...
  each answered by MISSION_ITEM_INT (or MISSION_ITEM); the wrong seq -> MISSION_ACK
  INVALID_SEQUENCE; after the last item MISSION_ACK ACCEPTED. Unanswered requests are resent
  after 1 s; 8 s without an item cancels the upload (OPERATION_CANCELLED). An upload from someone
  else meanwhile is DENIED; a new MISSION_COUNT from the same uploader restarts it. Count 0 clears.
- Download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST_INT -> MISSION_ITEM_INT,
  MISSION_REQUEST -> MISSION_ITEM; a seq beyond the mission -> MISSION_ACK INVALID_SEQUENCE;
  during an upload -> DENIED.
- MISSION_CLEAR_ALL -> MISSION_ACK ACCEPTED (ERROR during an upload:
  MissionItemProtocol::handle_mission_clear_all); only home remains.
- One upload at a time; downloads keep no state, so an upload may start during someone's
  download (whose next MISSION_REQUEST_INT is then DENIED).
- MISSION_CURRENT: seq (the current item, 0 until a mission runs), total, mission_state
  NO_MISSION (1) with no waypoint else NOT_STARTED (2): the stub never runs a mission (no AUTO).
Only mission type 0 (flight plan) is stored; fence and rally requests get MISSION_ACK UNSUPPORTED.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

from pymavlink.dialects.v20 import ardupilotmega as mavlink

RESEND_REQUEST_S = 1.0             # MissionItemProtocol::update: 1000 ms (+ stream slowdown)
UPLOAD_TIMEOUT_S = 8.0             # upload_timeout_ms
MAX_ITEMS = 700                    # the stub's storage (ArduPilot's depends on the board)
GLOBAL_FRAMES = (mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT,
                 mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                 mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT)


@dataclass(frozen=True)
class Item:
    """A stored item in MISSION_ITEM_INT terms (x, y: 1e7 degrees global, metres x 1e4 local)."""
    frame: int
    command: int
    current: int
    autocontinue: int
    params: tuple[float, float, float, float]
    x: int
    y: int
    z: float


def item_from_message(msg) -> Item:
    params = (float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4))
    if msg.get_type() == "MISSION_ITEM_INT":
        x, y = int(msg.x), int(msg.y)
    else:                                       # MISSION_ITEM: floats in degrees or metres
        scale = 1e7 if msg.frame in GLOBAL_FRAMES else 1e4
        x, y = int(round(msg.x * scale)), int(round(msg.y * scale))
    return Item(int(msg.frame), int(msg.command), int(msg.current), int(msg.autocontinue),
                params, x, y, float(msg.z))


class MissionStore:
    def __init__(self, home_lat_lon_alt) -> None:
        """``home_lat_lon_alt()``: home now (degrees, degrees, metres above sea level)."""
        self._home = home_lat_lon_alt
        self.items: list[Item] = []             # seq 1.. (home is made on the fly)
        self.current_seq = 0
        self.uploads = 0
        self._upload: dict | None = None        # {from, count, next, items, last_rx, last_req}

    # ---------------------------------------------------------------- state
    @property
    def count(self) -> int:
        return len(self.items) + 1

    def home_item(self) -> Item:
        lat, lon, alt = self._home()
        return Item(mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 1,
                    (0.0, 0.0, 0.0, 0.0), int(round(lat * 1e7)), int(round(lon * 1e7)), alt)

    def item(self, seq: int) -> Item:
        return self.home_item() if seq == 0 else self.items[seq - 1]

    def mission_current(self):
        total = len(self.items)
        state = mavlink.MISSION_STATE_NO_MISSION if total == 0 else \
            mavlink.MISSION_STATE_NOT_STARTED
        return mavlink.MAVLink_mission_current_message(self.current_seq, total, state, 0)

    # ---------------------------------------------------------------- handlers
    def handle(self, msg, t_s: float) -> list:
        kind = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if getattr(msg, "mission_type", 0) != mavlink.MAV_MISSION_TYPE_MISSION:
            return [self._ack(src, mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type)]
        if kind == "MISSION_COUNT":
            return self._on_count(src, int(msg.count), t_s)
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            return self._on_item(src, msg, t_s)
        if kind == "MISSION_REQUEST_LIST":
            if self._upload is not None:
                return [self._ack(src, mavlink.MAV_MISSION_DENIED)]
            return [mavlink.MAVLink_mission_count_message(*src, self.count, 0)]
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            return self._on_request(src, int(msg.seq), kind == "MISSION_REQUEST_INT")
        if kind == "MISSION_CLEAR_ALL":
            if self._upload is not None:
                return [self._ack(src, mavlink.MAV_MISSION_ERROR)]
            self.items, self.current_seq = [], 0
            return [self._ack(src, mavlink.MAV_MISSION_ACCEPTED), self.mission_current()]
        if kind == "MISSION_SET_CURRENT":
            if 0 <= msg.seq < self.count:
                self.current_seq = int(msg.seq)
            return [self.mission_current()]
        return []

    def _ack(self, dest, result: int, mission_type: int = 0):
        return mavlink.MAVLink_mission_ack_message(*dest, result, mission_type)

    def _request(self, dest, seq: int):
        return mavlink.MAVLink_mission_request_message(*dest, seq, 0)

    def _on_count(self, src, count: int, t_s: float) -> list:
        up = self._upload
        if up is not None and up["from"] != src:
            return [self._ack(src, mavlink.MAV_MISSION_DENIED)]
        if count > MAX_ITEMS:
            return [self._ack(src, mavlink.MAV_MISSION_NO_SPACE)]
        if count == 0:
            self._upload = None
            return self._complete(src, [])
        self._upload = {"from": src, "count": count, "items": [], "last_rx": t_s, "last_req": t_s}
        return [self._request(src, 0)]

    def _on_item(self, src, msg, t_s: float) -> list:
        up = self._upload
        if up is None or up["from"] != src:
            return [self._ack(src, mavlink.MAV_MISSION_DENIED)]
        if msg.seq != len(up["items"]):
            return [self._ack(src, mavlink.MAV_MISSION_INVALID_SEQUENCE)]
        up["items"].append(item_from_message(msg))
        up["last_rx"] = up["last_req"] = t_s
        if len(up["items"]) == up["count"]:
            self._upload = None
            return self._complete(src, up["items"])
        return [self._request(src, len(up["items"]))]

    def _complete(self, src, items: list[Item]) -> list:
        self.items = items[1:]                 # item 0 is home: ArduPilot keeps its own
        self.current_seq = 0
        self.uploads += 1
        return [self._ack(src, mavlink.MAV_MISSION_ACCEPTED), self.mission_current()]

    def _on_request(self, src, seq: int, as_int: bool) -> list:
        if self._upload is not None:
            return [self._ack(src, mavlink.MAV_MISSION_DENIED)]
        if not 0 <= seq < self.count:
            return [self._ack(src, mavlink.MAV_MISSION_INVALID_SEQUENCE)]
        it = self.item(seq)
        current = 1 if seq == self.current_seq else 0
        if as_int:
            return [mavlink.MAVLink_mission_item_int_message(
                *src, seq, it.frame, it.command, current, it.autocontinue, *it.params,
                it.x, it.y, it.z, 0)]
        scale = 1e7 if it.frame in GLOBAL_FRAMES else 1e4
        return [mavlink.MAVLink_mission_item_message(
            *src, seq, it.frame, it.command, current, it.autocontinue, *it.params,
            it.x / scale, it.y / scale, it.z, 0)]

    def tick(self, t_s: float) -> list:
        """Resend the pending request after 1 s; cancel the upload after 8 s without an item."""
        up = self._upload
        if up is None:
            return []
        if t_s - up["last_rx"] > UPLOAD_TIMEOUT_S:
            self._upload = None
            return [self._ack(up["from"], mavlink.MAV_MISSION_OPERATION_CANCELLED)]
        if t_s - up["last_req"] > RESEND_REQUEST_S:
            up["last_req"] = t_s
            return [self._request(up["from"], len(up["items"]))]
        return []
