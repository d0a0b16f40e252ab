"""Other clients' mission transfers, as the vehicle's side of them shows. Pure: time passed in.

ArduCopter serves one mission upload at a time and downloads without any state
(libraries/GCS_MAVLink/MissionItemProtocol.cpp): while an upload runs (``receiving``), a
MISSION_REQUEST_LIST or MISSION_REQUEST_INT from anyone is refused with MISSION_ACK DENIED, and a
MISSION_COUNT from anyone but the uploader is DENIED too; the upload ends with the vehicle's
MISSION_ACK to the uploader (ACCEPTED, or an error), or OPERATION_CANCELLED after
``upload_timeout_ms`` (8 s) without an item. A download by someone else is not refused, but a
ground station that is listing the mission may take our MISSION_COUNT and MISSION_ITEM_INT for
its own (MAVProxy's wp module does: it reads any MISSION_COUNT while it lists).

Behind a router (MAVProxy, mavlink-router) the companion hears the vehicle's side of another
client's transfer: MISSION_REQUEST / MISSION_REQUEST_INT to the uploader, MISSION_COUNT and
MISSION_ITEM(_INT) to a downloader, MISSION_ACK to the uploader. On its own serial port it hears
none of it (ArduPilot answers on the requester's link): then refusals (DENIED) and MISSION_CURRENT
are all it has.

``TransferWatch`` turns that traffic into "busy until" and "a mission was uploaded".
"""
from __future__ import annotations

from dataclasses import dataclass

from companion.mavlink import mission_codec as mc

UPLOAD_TIMEOUT_S = 8.0       # ArduPilot's upload_timeout_ms: the upload is over after this quiet
DOWNLOAD_QUIET_S = 2.0       # another client's download: over after this long without an item


@dataclass(frozen=True)
class Transfer:
    kind: str                  # 'upload' or 'download'
    peer: tuple[int, int]      # (system, component) of the other client
    last_t_s: float


class TransferWatch:
    def __init__(self, own_component: int) -> None:
        self.own_component = own_component
        self.transfers: dict[tuple[int, int], Transfer] = {}
        self.uploads_seen = 0              # uploads by others the vehicle accepted

    def _for_us(self, event) -> bool:
        return event.target_component == self.own_component

    def on_event(self, t_s: float, event) -> str | None:
        """A mission message from the vehicle. Returns 'uploaded' when the vehicle accepted
        another client's upload (or clear): the mission on the vehicle changed."""
        if getattr(event, "mission_type", mc.MISSION_TYPE_MISSION) != mc.MISSION_TYPE_MISSION:
            return None
        if self._for_us(event):
            return None
        peer = (event.target_system, event.target_component)
        if isinstance(event, mc.MissionRequestSeen):
            self.transfers[peer] = Transfer("upload", peer, t_s)
        elif isinstance(event, (mc.MissionCount, mc.MissionItem)):
            self.transfers[peer] = Transfer("download", peer, t_s)
        elif isinstance(event, mc.MissionAck):
            before = self.transfers.pop(peer, None)
            # The vehicle acknowledges uploads and clears only (a downloader acknowledges the
            # vehicle): ACCEPTED to another client is a new mission, seen or not its requests.
            if event.result == mc.MISSION_ACCEPTED and (before is None or before.kind == "upload"):
                self.uploads_seen += 1
                return "uploaded"
        return None

    def busy(self, t_s: float) -> Transfer | None:
        """Another client's transfer still running at ``t_s`` (the oldest), or None."""
        for peer, transfer in list(self.transfers.items()):
            quiet_s = UPLOAD_TIMEOUT_S if transfer.kind == "upload" else DOWNLOAD_QUIET_S
            if t_s - transfer.last_t_s > quiet_s:
                del self.transfers[peer]
        return next(iter(self.transfers.values()), None)
