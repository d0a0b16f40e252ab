"""sitl-stub --route: ArduPilot's routing rules (libraries/GCS_MAVLink/MAVLink_routing.cpp, as the
ArduPilot developer wiki's "MAVLink Routing in ArduPilot" states them), on pymavlink messages."""
import os

os.environ["MAVLINK20"] = "1"
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from sitl_stub.routing import Route, Router  # noqa: E402


def from_(sysid, compid, msg):
    mav = mavlink.MAVLink(None, sysid, compid)
    return mav.decode(bytearray(msg.pack(mav)))


def heartbeat(sysid, compid):
    return from_(sysid, compid, mavlink.MAVLink_heartbeat_message(18, 8, 0, 0, 4, 3))


def router_with_companion_and_gcs():
    router = Router(1, (1, 100))
    router.route("udp:companion", heartbeat(1, 191))
    router.route("tcp:gcs", heartbeat(255, 190))
    return router


def test_a_request_for_the_companion_goes_to_its_link_only_not_to_the_autopilot():
    router = router_with_companion_and_gcs()
    msg = from_(255, 190, mavlink.MAVLink_param_request_list_message(1, 191))
    assert router.route("tcp:gcs", msg) == Route(False, ("udp:companion",))


def test_a_request_for_the_autopilot_stays_here():
    router = router_with_companion_and_gcs()
    msg = from_(255, 190, mavlink.MAVLink_param_request_list_message(1, 1))
    assert router.route("tcp:gcs", msg) == Route(True, ())


def test_component_zero_is_answered_here_and_by_every_component_of_the_system():
    router = router_with_companion_and_gcs()
    msg = from_(255, 190, mavlink.MAVLink_param_request_list_message(1, 0))
    assert router.route("tcp:gcs", msg) == Route(True, ("udp:companion",))


def test_untargeted_messages_go_everywhere_else_and_are_handled_here():
    router = router_with_companion_and_gcs()
    msg = from_(1, 191, mavlink.MAVLink_param_value_message(b"CA_SAFE_DIST", 12.0, 9, 13, 0))
    assert router.route("udp:companion", msg) == Route(True, ("tcp:gcs",))


def test_a_component_never_seen_is_ours_to_answer_and_a_gone_client_is_forgotten():
    router = router_with_companion_and_gcs()
    msg = from_(255, 190, mavlink.MAVLink_param_request_list_message(1, 154))
    assert router.route("tcp:gcs", msg) == Route(True, ())
    router.forget("udp:companion")
    msg = from_(255, 190, mavlink.MAVLink_param_request_list_message(1, 191))
    assert router.route("tcp:gcs", msg).to == ()


def test_a_client_claiming_the_stubs_own_ids_teaches_no_route():
    router = Router(1, (1, 100))
    router.route("tcp:spoof", heartbeat(1, 1))
    router.route("tcp:gcs", heartbeat(255, 190))
    msg = from_(255, 190, mavlink.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0))
    assert router.route("tcp:gcs", msg) == Route(True, ())
