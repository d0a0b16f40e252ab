"""Telemetry stream scheduling on simulated time, as ArduPilot does it.

Each emitted message belongs to an ArduPilot stream whose rate is the SR0_<stream> parameter.
MAV_CMD_SET_MESSAGE_INTERVAL overrides one message; REQUEST_DATA_STREAM sets a whole stream's
rate and clears the overrides of its messages (GCS_MAVLINK::handle_request_data_stream ->
initialise_message_intervals_for_stream). ArduPilot keeps both per link (each GCS_MAVLINK
channel has its own streamRates and message intervals): a link that asks gets its own
scheduler (``LinkSchedulers``), started from the shared one, so a companion on its own port keeps
its rates whatever a ground station on another port asks for. The SR0_ parameters are every
link's rates at boot (the stub keeps SR0_ and SR1_ equal). Messages are emitted on physics steps,
so the highest effective rate is 1 / vehicle.dt_s.
"""
from __future__ import annotations

from .params import ParamTable

MSG_HEARTBEAT = 0
MSG_SYS_STATUS = 1
MSG_SYSTEM_TIME = 2
MSG_GPS_RAW_INT = 24
MSG_GPS_GLOBAL_ORIGIN = 49
MSG_BATTERY_STATUS = 147
MSG_EKF_STATUS_REPORT = 193
MSG_EXTENDED_SYS_STATE = 245
MSG_ATTITUDE = 30
MSG_LOCAL_POSITION_NED = 32
MSG_GLOBAL_POSITION_INT = 33
MSG_POSITION_TARGET_LOCAL_NED = 85
MSG_SIMSTATE = 164
MSG_HOME_POSITION = 242
MSG_MISSION_CURRENT = 42

# MAV_DATA_STREAM ids (REQUEST_DATA_STREAM) -> SRn_ parameter suffix.
DATA_STREAM_SUFFIX = {1: "RAW_SENS", 2: "EXT_STAT", 3: "RC_CHAN", 4: "RAW_CTRL", 6: "POSITION",
                      10: "EXTRA1", 11: "EXTRA2", 12: "EXTRA3"}
MAV_DATA_STREAM_ALL = 0

# Which stream each message rides on (as in ArduCopter's GCS_MAVLink_Copter.cpp stream lists,
# except POSITION_TARGET_LOCAL_NED, which the stub sends with the position stream while in
# GUIDED). EXTENDED_SYS_STATE is in no stream on ArduCopter: only SET_MESSAGE_INTERVAL sends it.
STREAM_OF_MESSAGE = {
    MSG_SYS_STATUS: "EXT_STAT",
    MSG_GPS_RAW_INT: "EXT_STAT",
    MSG_MISSION_CURRENT: "EXT_STAT",      # ArduCopter: MSG_CURRENT_WAYPOINT in EXTENDED_STATUS
    MSG_BATTERY_STATUS: "EXTRA3",
    MSG_EKF_STATUS_REPORT: "EXTRA3",
    MSG_GLOBAL_POSITION_INT: "POSITION",
    MSG_LOCAL_POSITION_NED: "POSITION",
    MSG_POSITION_TARGET_LOCAL_NED: "POSITION",
    MSG_ATTITUDE: "EXTRA1",
    MSG_SIMSTATE: "EXTRA1",
    MSG_SYSTEM_TIME: "EXTRA3",
}
HEARTBEAT_INTERVAL_S = 1.0
# Messages that can be streamed at all (SET_MESSAGE_INTERVAL on anything else is refused).
STREAMABLE = (MSG_HEARTBEAT, *STREAM_OF_MESSAGE, MSG_HOME_POSITION, MSG_GPS_GLOBAL_ORIGIN,
              MSG_EXTENDED_SYS_STATE)

_DISABLED = -1.0


class StreamScheduler:
    """Decides which periodic messages are due at a simulated time."""

    streamable: tuple[int, ...] = STREAMABLE      # the messages it may send, in sending order

    def __init__(self, params: ParamTable) -> None:
        self._params = params
        self._override_s: dict[int, float] = {}   # msg id -> interval s, or _DISABLED
        self._next_due_s: dict[int, float] = {}
        self._own_rates_hz: dict[str, float] | None = None   # a link's own SRn_ (None: params)
        # --fixed-rate: messages sent at this interval whatever anyone asks (shared by every link)
        self.fixed_s: dict[int, float] = {}

    def clone_for_link(self) -> "StreamScheduler":
        """A link's own scheduler, as the shared one stands now (same intervals, same due
        times: the link's messages carry on without a gap or a burst)."""
        other = type(self)(self._params)
        other.fixed_s = self.fixed_s
        other._override_s = dict(self._override_s)
        other._next_due_s = dict(self._next_due_s)
        other._own_rates_hz = dict(self._own_rates_hz) if self._own_rates_hz is not None \
            else {suffix: self._params.stream_rate_hz(suffix)
                  for suffix in DATA_STREAM_SUFFIX.values()}
        return other

    def _stream_rate_hz(self, suffix: str) -> float:
        if self._own_rates_hz is not None:
            return self._own_rates_hz[suffix]
        return self._params.stream_rate_hz(suffix)

    def interval_s(self, msg_id: int) -> float | None:
        """Current interval of a message in seconds, or None if it is not being sent."""
        if msg_id in self.fixed_s:
            return self.fixed_s[msg_id]
        if msg_id in self._override_s:
            value = self._override_s[msg_id]
            return None if value == _DISABLED else value
        return self.default_interval_s(msg_id)

    def default_interval_s(self, msg_id: int) -> float | None:
        if msg_id == MSG_HEARTBEAT:
            return HEARTBEAT_INTERVAL_S
        suffix = STREAM_OF_MESSAGE.get(msg_id)
        if suffix is None:
            return None
        rate_hz = self._stream_rate_hz(suffix)
        return 1.0 / rate_hz if rate_hz > 0 else None

    def set_message_interval(self, msg_id: int, interval_us: float) -> bool:
        """MAV_CMD_SET_MESSAGE_INTERVAL: -1 disables, 0 restores the default, > 0 sets it.
        Returns False for a message the stub cannot stream or a meaningless interval."""
        if msg_id not in STREAMABLE:
            return False
        if interval_us == -1:
            self._override_s[msg_id] = _DISABLED
        elif interval_us == 0:
            self._override_s.pop(msg_id, None)
        elif interval_us > 0:
            self._override_s[msg_id] = interval_us / 1e6
        else:
            return False
        self._next_due_s.pop(msg_id, None)
        return True

    def request_data_stream(self, stream_id: int, rate_hz: int, start: bool) -> bool:
        """REQUEST_DATA_STREAM: set the stream's SR0_ rate (all streams for MAV_DATA_STREAM_ALL)."""
        if stream_id == MAV_DATA_STREAM_ALL:
            suffixes = list(DATA_STREAM_SUFFIX.values())
        elif stream_id in DATA_STREAM_SUFFIX:
            suffixes = [DATA_STREAM_SUFFIX[stream_id]]
        else:
            return False
        rate = max(0.0, float(rate_hz)) if start else 0.0
        for suffix in suffixes:
            if self._own_rates_hz is not None:
                self._own_rates_hz[suffix] = rate
            else:
                self._params.set(f"SR0_{suffix}", rate)
            for msg_id, msg_suffix in STREAM_OF_MESSAGE.items():
                if msg_suffix == suffix:
                    self._override_s.pop(msg_id, None)
                    self._next_due_s.pop(msg_id, None)
        return True

    def rates_changed(self) -> None:
        """Call after an SRn_ parameter changed, so new rates take effect at once (a PARAM_SET
        of SRn_ sets every link's rates: the stub has one parameter set)."""
        if self._own_rates_hz is not None:
            self._own_rates_hz = {suffix: self._params.stream_rate_hz(suffix)
                                  for suffix in DATA_STREAM_SUFFIX.values()}
        self._next_due_s.clear()

    def due(self, t_s: float) -> list[int]:
        """Message ids due at simulated time t_s; advances their next-due times."""
        out = []
        for msg_id in self.streamable:
            interval = self.interval_s(msg_id)
            if interval is None:
                self._next_due_s.pop(msg_id, None)
                continue
            next_due = self._next_due_s.get(msg_id, t_s)
            if t_s + 1e-9 >= next_due:
                out.append(msg_id)
                next_due += interval
                if next_due <= t_s:
                    next_due = t_s + interval
                self._next_due_s[msg_id] = next_due
        return out


class LinkSchedulers:
    """The shared scheduler (every link that never asked) and the links' own ones."""

    def __init__(self, params: ParamTable, scheduler=None) -> None:
        """``scheduler``: the StreamScheduler class (the PX4 face's has PX4's defaults)."""
        self.shared = (scheduler or StreamScheduler)(params)
        self.own: dict[str, StreamScheduler] = {}

    def for_link(self, link: str | None) -> StreamScheduler:
        """The scheduler a stream request from ``link`` changes (None: the shared one, for a
        caller that does not say where the request came from)."""
        if link is None:
            return self.shared
        if link not in self.own:
            self.own[link] = self.shared.clone_for_link()
        return self.own[link]

    def of(self, link: str) -> StreamScheduler:
        """The scheduler whose messages ``link`` receives."""
        return self.own.get(link, self.shared)

    def forget(self, link: str) -> None:
        self.own.pop(link, None)

    def rates_changed(self) -> None:
        self.shared.rates_changed()
        for scheduler in self.own.values():
            scheduler.rates_changed()
