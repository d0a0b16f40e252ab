"""The link section of the service config: identities, the autopilot's dialect, link timing."""
from __future__ import annotations

from dataclasses import dataclass

from companion.config.checks import require_positive
from companion.config.loader import require
from companion.onboard.autopilot_dialect import AUTOPILOTS


@dataclass(frozen=True)
class LinkConfig:
    """Identities and link timing. ``None`` ids are discovered from the vehicle's heartbeat."""
    component_id: int = 191                   # MAV_COMP_ID_ONBOARD_COMPUTER
    system_id: int | None = None              # ours; None: the vehicle's
    vehicle_system_id: int | None = None      # pin the vehicle; None: first autopilot heartbeat
    vehicle_component_id: int | None = None   # None: the component of that heartbeat
    camera_component_id: int = 100            # MAV_COMP_ID_CAMERA: obstacle reports come from here
    guided_custom_mode: int = 4               # ArduCopter GUIDED
    # The autopilot's dialect: 'auto' from the vehicle's HEARTBEAT.autopilot (12: PX4, anything
    # else: ArduPilot), or pinned (companion/onboard/autopilot_dialect.py; PX4: the px4 section)
    autopilot: str = "auto"
    heartbeat_rate_hz: float = 1.0
    heartbeat_timeout_s: float = 3.0          # vehicle heartbeat older than this: stop commanding
    reconnect_interval_s: float = 1.0
    inbox_size: int = 1000
    # A camera frame (its reports of one capture time) is complete once this long has passed
    # after its last report with nothing else arriving (link time); null: when the first message
    # not of it arrives (on a stub or camera that ends each burst, the next burst: up to one
    # step late). Reports of a frame that came after it closed are counted and dropped.
    camera_frame_idle_s: float | None = None
    signing_key_file: str | None = None       # MAVLink 2 signing: file with the key, 64 hex chars
    # SYS_STATUS with the obstacle-avoidance bit (companion/onboard/health.py). false: none, for a
    # ground station that reads a non-autopilot's SYS_STATUS as the vehicle's (docs/messages.md,
    # "Identity and health": MAVProxy aimed at component 191 says "fence breach").
    sys_status: bool = True
    # PARAM_VALUEs a second while a ground station's PARAM_REQUEST_LIST is answered (one list at a
    # time: companion/onboard/param_pacing.py). 10: 370 bytes/s (37-byte MAVLink 2 PARAM_VALUE),
    # 6% of a 57,600-baud radio's 5,760 bytes/s (8N1); ArduPilot lets its own list use 30%.
    param_rate_hz: float = 10.0

    def __post_init__(self) -> None:
        for key in ("component_id", "camera_component_id"):
            require(1 <= getattr(self, key) <= 255, key, getattr(self, key), "an id in [1, 255]")
        for key in ("system_id", "vehicle_system_id", "vehicle_component_id"):
            value = getattr(self, key)
            require(value is None or 1 <= value <= 255, key, value, "an id in [1, 255] or null")
        require(self.guided_custom_mode >= 0, "guided_custom_mode", self.guided_custom_mode,
                "a custom mode number >= 0")
        require(self.autopilot in AUTOPILOTS, "autopilot", self.autopilot,
                " | ".join(AUTOPILOTS))
        for key in ("heartbeat_rate_hz", "heartbeat_timeout_s", "reconnect_interval_s",
                    "param_rate_hz"):
            require_positive(key, getattr(self, key))
        require(self.inbox_size >= 10, "inbox_size", self.inbox_size, "an integer >= 10")
        require(self.camera_frame_idle_s is None or 0.0 < self.camera_frame_idle_s <= 0.5,
                "camera_frame_idle_s", self.camera_frame_idle_s,
                "null (off) or seconds in (0, 0.5]")
        require(self.signing_key_file is None or self.signing_key_file.strip() != "",
                "signing_key_file", self.signing_key_file, "a file name or null")
