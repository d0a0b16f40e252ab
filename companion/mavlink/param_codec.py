"""The parameter protocol's messages <-> the parameter server's requests and values (mavlink/param_messages.py).

PARAM_REQUEST_LIST, PARAM_REQUEST_READ and PARAM_SET come in as :class:`ParamRequest`; a
:class:`ParamValue` goes out as PARAM_VALUE. Values travel as float32 with integers cast to float
(MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST, as ArduPilot does), so MAVProxy, Mission Planner and
QGroundControl read them as ArduPilot parameters. A param_id is up to 16 bytes, NUL-padded; bytes
that are not ASCII are kept as replacement characters (and match no parameter).
"""
from __future__ import annotations

from companion.mavlink.dialect import mavlink
from companion.mavlink.param_messages import ParamRequest, ParamValue


def _name(param_id) -> str:
    if isinstance(param_id, (bytes, bytearray)):
        param_id = bytes(param_id).split(b"\0", 1)[0].decode("ascii", "replace")
    return str(param_id).split("\0", 1)[0][:16]


def _signed(msg) -> bool:
    return bool(getattr(msg, "_signed", False))


def _request_list(msg, sysid: int, compid: int) -> ParamRequest:
    return ParamRequest("list", sysid, compid, int(msg.target_system), int(msg.target_component),
                        signed=_signed(msg))


def _request_read(msg, sysid: int, compid: int) -> ParamRequest:
    return ParamRequest("read", sysid, compid, int(msg.target_system), int(msg.target_component),
                        name=_name(msg.param_id), index=int(msg.param_index), signed=_signed(msg))


def _set(msg, sysid: int, compid: int) -> ParamRequest:
    value = float(msg.param_value)
    return ParamRequest("set", sysid, compid, int(msg.target_system), int(msg.target_component),
                        name=_name(msg.param_id), value=value,
                        param_type=int(msg.param_type), signed=_signed(msg))


DECODERS = {
    "PARAM_REQUEST_LIST": _request_list,
    "PARAM_REQUEST_READ": _request_read,
    "PARAM_SET": _set,
}


def param_value(value: ParamValue) -> mavlink.MAVLink_param_value_message:
    return mavlink.MAVLink_param_value_message(value.name.encode("ascii"), value.value,
                                               value.param_type, value.count, value.index)
