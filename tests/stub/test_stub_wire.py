"""Wire-level pieces without sockets: garbage handling, packing of every emitted message type."""
import math

import numpy as np

from hypothesis import given, settings, strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_stub import camera, telemetry
from sitl_stub.links import LinkHub, _Client
from sitl_stub.vehicle import Odometry
from sitl_stub.world import load_scenario

from .support import PAPER

SC = load_scenario(PAPER)


def _hub():
    got = []
    hub = LinkHub(None, None, 1, lambda name, msg: got.append(msg))
    return hub, got


def _valid_bytes():
    enc = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    return bytes(mavlink.MAVLink_param_request_read_message(1, 1, b"GUID_TIMEOUT", -1).pack(enc))


@settings(max_examples=60, deadline=None)
@given(st.binary(min_size=1, max_size=300))
def test_garbage_never_stops_parsing_and_is_counted(junk):
    hub, got = _hub()
    client = _Client("test", 1, None, 1)
    hub._feed(client, junk, per_message_drop=False)
    # a valid message after enough bytes to flush any half-parsed frame is still delivered
    hub._feed(client, b"\x00" * 300 + _valid_bytes(), per_message_drop=False)
    assert any(m.get_type() == "PARAM_REQUEST_READ" for m in got)
    assert hub.statistics().bad_data >= 1


def test_crc_error_is_counted_and_dropped():
    hub, got = _hub()
    frame = bytearray(_valid_bytes())
    frame[-1] ^= 0xFF
    hub._feed(_Client("test", 1, None, 1), bytes(frame) + _valid_bytes(), per_message_drop=False)
    assert len(got) == 1 and hub.statistics().bad_data == 1


def test_components_have_their_own_sequence_numbers():
    client = _Client("test", 1, None, 1)
    dec = mavlink.MAVLink(None)
    seqs = []
    for comp in (1, 1, 100, 1, 100):
        msg = dec.decode(bytearray(client.encode(comp, telemetry.heartbeat_camera())))
        seqs.append((msg.get_srcComponent(), msg.get_seq()))
    assert seqs == [(1, 0), (1, 1), (100, 0), (1, 2), (100, 1)]


def _telemetry_burst():
    """Messages of every kind the stub streams, with trailing zero bytes (truncated payloads)."""
    odom = Odometry(north_m=3.0, east_m=-2.0, yaw_rad=0.4, speed_mps=1.5, yaw_rate_rad_s=0.0,
                    vel_north_mps=1.2, vel_east_mps=0.7, up_m=10.0, vel_up_mps=0.0)
    return [(1, telemetry.heartbeat_autopilot(4, True, False)),
            (1, telemetry.attitude(12.3, 0.4, 0.0)),
            (1, telemetry.local_position_ned(12.3, odom, 3.0, -2.0)),
            (100, telemetry.heartbeat_camera()),
            (1, mavlink.MAVLink_param_request_read_message(1, 1, b"GUID_TIMEOUT", -1)),
            (100, mavlink.MAVLink_obstacle_distance_message(
                123, 0, [300] * 10 + [0] * 62, 5, 20, 2000, 5.0, 0.0, mavlink.MAV_FRAME_BODY_FRD))]


def test_a_message_packed_for_one_link_is_patched_for_another_byte_for_byte():
    """broadcast() packs each message once: another link's copy (its own sequence number and CRC)
    is the frame pymavlink would have packed for it."""
    first, second, reference = (_Client(name, 1, None, 1) for name in ("a", "b", "ref"))
    for _ in range(3):               # the links' sequence numbers differ
        second.encode(1, telemetry.heartbeat_camera())
        reference.encode(1, telemetry.heartbeat_camera())
    for _ in range(300):             # through the wrap at 256
        for comp, msg in _telemetry_burst():
            packed = first.encode(comp, msg)
            assert second.encode(comp, msg, packed) == reference.encode(comp, msg)
    signed = _Client("signed", 1, bytes(range(32)), 2)
    comp, msg = _telemetry_burst()[1]
    assert len(signed.encode(comp, msg, first.encode(comp, msg))) == \
        len(first.encode(comp, msg)) + 13          # a signing link packs (and signs) its own


def test_every_emitted_message_packs_and_angles_stay_in_range():
    enc = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    dec = mavlink.MAVLink(None)
    odom = Odometry(1.0, 2.0, math.pi, -0.3, 0.1, 0.3, -0.0, up_m=10.0, vel_up_mps=0.5)
    origin = SC.world.origin
    dets = camera.observe(0.0, 0.0, 0.0, [(1, 20.0, 0.0, 2.0)], SC.sensor,
                          np.random.default_rng(0))
    msgs = [telemetry.heartbeat_autopilot(4, True), telemetry.sys_status(True, True, 12600, 150, 99),
            telemetry.system_time(1.0, 1.7e9), telemetry.attitude(1.0, odom.yaw_rad, odom.yaw_rate_rad_s),
            telemetry.local_position_ned(1.0, odom, 1.0, 2.0),
            telemetry.global_position_int(1.0, odom, 1.0, 2.0, origin, 0.0),
            telemetry.home_position(origin, 20.0, 0.0, 0.0, 1.0), telemetry.autopilot_version(),
            telemetry.gps_raw_int(1.0, True, -35.0, 149.0, 594.0, 1.2, 5.0, 0.3),
            telemetry.gps_raw_int(1.0, False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
            telemetry.ekf_status_report(True), telemetry.battery_status(12600, 150, 10, 99),
            telemetry.extended_sys_state(2, 0), telemetry.gps_global_origin(origin, 1.0),
            telemetry.obstacle_distance_3d(dets[0], 1.0, SC.sensor),
            telemetry.obstacle_distance(dets, 1.0, SC.sensor)]
    for m in msgs:
        out = dec.decode(bytearray(m.pack(enc)))
        assert out.get_type() == m.get_type()
    att = dec.decode(bytearray(telemetry.attitude(1.0, odom.yaw_rad, odom.yaw_rate_rad_s).pack(enc)))
    assert -math.pi < att.yaw <= math.pi
    gpi = dec.decode(bytearray(telemetry.global_position_int(1.0, odom, 1.0, 2.0, origin,
                                                             0.0).pack(enc)))
    assert gpi.hdg == 18000 and gpi.relative_alt == 10000 and gpi.vx == 30 and gpi.vz == -50
    assert gpi.alt == round((origin.alt_m + 10.0) * 1000)
    lpn = dec.decode(bytearray(telemetry.local_position_ned(1.0, odom, 1.0, 2.0).pack(enc)))
    assert (lpn.z, lpn.vz) == (-10.0, -0.5)
    od = dec.decode(bytearray(telemetry.obstacle_distance(dets, 1.0, SC.sensor).pack(enc)))
    assert len(od.distances) == 72 and abs(min(od.distances) - 1800) <= 50   # noisy range - radius


def test_a_steps_burst_goes_out_over_udp_in_few_datagrams_of_whole_packets(tmp_path):
    """One step's telemetry shares datagrams (up to MAX_DATAGRAM_BYTES, whole packets each):
    the position and the attitude of one step arrive together."""
    import socket

    from sitl_stub.links import MAX_DATAGRAM_BYTES

    from .support import start_stub

    stub = start_stub(tmp_path, "--speedup", "5", "--udp", "127.0.0.1:0")
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.settimeout(5.0)
    try:
        client = mavlink.MAVLink(None, 255, 190)
        sock.sendto(client.heartbeat_encode(6, 8, 0, 0, 0).pack(client), ("127.0.0.1", stub.udp_port))
        parser = mavlink.MAVLink(None)
        together = 0
        for _ in range(20):
            datagram = sock.recv(65536)
            assert len(datagram) <= MAX_DATAGRAM_BYTES
            msgs = parser.parse_buffer(datagram) or []
            assert msgs and all(m.get_type() != "BAD_DATA" for m in msgs)
            assert len(parser.buf) - parser.buf_index == 0          # no half packet left over
            kinds = [m.get_type() for m in msgs]
            together += "LOCAL_POSITION_NED" in kinds and "ATTITUDE" in kinds
        assert together >= 5
    finally:
        sock.close()
        stub.stop()
