"""End to end: `sitl-stub` as a real subprocess, a plain pymavlink client over real sockets."""
import math
import socket
import subprocess

import pytest

from .support import (PAPER, arm_guided, command, connect_tcp, connect_udp, mavlink,
                      read_truth_log, send_velocity, start_stub, stub_command, wait_for,
                      wait_heartbeat, wait_until)

MS = 1000.0


def fly(conn, vn, ve, sim_seconds, yaw=0.0, frame=mavlink.MAV_FRAME_LOCAL_NED, mask=0x09C7,
        collect=None, timeout_s=30.0):
    """Send the velocity target about every 0.5 s of simulated time for sim_seconds.

    Returns (time_boot_ms when the first target was sent, time_boot_ms of the last target).
    Simulated time is read from the messages' time_boot_ms, so this is independent of speedup.
    """
    state = {"t_ms": None}

    def note(msg):
        if hasattr(msg, "time_boot_ms"):
            state["t_ms"] = msg.time_boot_ms
        if collect is not None:
            collect.append(msg)

    assert wait_for(conn, lambda m: True, 5.0, "LOCAL_POSITION_NED", on_message=note)
    start_ms = last_ms = state["t_ms"]
    send_velocity(conn, vn, ve, yaw, mask, frame)
    while state["t_ms"] < start_ms + sim_seconds * MS:
        sent_at = state["t_ms"]
        got = wait_for(conn, lambda m: state["t_ms"] >= sent_at + 500, timeout_s, on_message=note)
        assert got is not None, "no telemetry"
        send_velocity(conn, vn, ve, yaw, mask, frame)
        last_ms = state["t_ms"]
    return start_ms, last_ms


def test_acceptance_paper_scenario(tmp_path):
    """The issue's acceptance check against --speedup 5."""
    stub = start_stub(tmp_path, "--speedup", "5", "--truth-log", str(tmp_path / "truth.jsonl"))
    conn = connect_tcp(stub.tcp_port)
    try:
        hb = wait_heartbeat(conn)
        assert hb is not None and hb.autopilot == 3 and hb.type == 2
        ack = command(conn, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 32, 100000)
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        arm_guided(conn)
        seen = []
        start_ms, last_ms = fly(conn, 5.0, 0.0, 12.0, collect=seen)
        positions = [m for m in seen if m.get_type() == "LOCAL_POSITION_NED"]
        first = next(m for m in positions if m.time_boot_ms >= start_ms)
        end = positions[-1]
        elapsed_s = (end.time_boot_ms - first.time_boot_ms) / MS
        covered = end.x - first.x
        assert elapsed_s > 10.0
        assert covered == pytest.approx(5.0 * elapsed_s, rel=0.30)
        assert abs(end.y - first.y) < 0.2 * covered
        obstacle_reports = [m for m in seen if m.get_type() == "OBSTACLE_DISTANCE_3D"]
        assert obstacle_reports and {m.obstacle_id for m in obstacle_reports} <= {1, 2}
        assert all(m.get_srcComponent() == 100 for m in obstacle_reports)
        # stopped 6 s (simulated) after the last target: the true position stops changing
        sim1 = wait_for(conn, lambda m: True, 20.0, "SIMSTATE") and wait_for(
            conn, lambda m: m.time_boot_ms >= last_ms + 6000, 20.0, "LOCAL_POSITION_NED")
        assert sim1 is not None
        a = wait_for(conn, lambda m: True, 5.0, "SIMSTATE")
        wait_for(conn, lambda m: m.time_boot_ms >= sim1.time_boot_ms + 1000, 10.0,
                 "LOCAL_POSITION_NED")
        b = wait_for(conn, lambda m: True, 5.0, "SIMSTATE")
        assert (a.lat, a.lng) == (b.lat, b.lng)
    finally:
        conn.close()
        assert stub.stop() == 0
    truth = read_truth_log(tmp_path / "truth.jsonl")
    stopped = [r for r in truth if r["t_s"] * MS >= last_ms + 6000]
    assert stopped and all(r["speed_mps"] == 0.0 for r in stopped)
    assert max(r["north_m"] for r in truth) > 60.0


def test_trajectory_follows_model_and_nan_and_frame_stop(tmp_path):
    log_path = tmp_path / "truth.jsonl"
    stub = start_stub(tmp_path, "--speedup", "10", "--truth-log", str(log_path), "--seed", "4")
    conn = connect_tcp(stub.tcp_port)
    try:
        assert wait_heartbeat(conn) is not None
        arm_guided(conn)
        _, north_end = fly(conn, 5.0, 0.0, 5.0)
        _, east_end = fly(conn, 0.0, 5.0, 6.0, yaw=math.pi / 2)
        send_velocity(conn, float("nan"), 0.0)                     # NaN: stop now
        nan_ms = wait_for(conn, lambda m: True, 5.0, "LOCAL_POSITION_NED").time_boot_ms
        assert wait_for(conn, lambda m: m.time_boot_ms > nan_ms + 3000, 20.0,
                        "LOCAL_POSITION_NED") is not None
        fly(conn, 5.0, 0.0, 4.0)
        send_velocity(conn, 5.0, 0.0, frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
        frame_ms = wait_for(conn, lambda m: True, 5.0, "LOCAL_POSITION_NED").time_boot_ms
        assert wait_for(conn, lambda m: m.time_boot_ms > frame_ms + 3000, 20.0,
                        "LOCAL_POSITION_NED") is not None
    finally:
        conn.close()
        assert stub.stop() == 0
    rows = read_truth_log(log_path)
    dt = 0.1
    for a, b in zip(rows, rows[1:]):
        # the multicopter model, step by step: the velocity vector moves the vehicle
        assert b["north_m"] == pytest.approx(a["north_m"] + b["vel_north_mps"] * dt, abs=1e-9)
        assert b["east_m"] == pytest.approx(a["east_m"] + b["vel_east_mps"] * dt, abs=1e-9)
        assert b["up_m"] == pytest.approx(max(0.0, a["up_m"] + b["vel_up_mps"] * dt), abs=1e-9)
        dyaw = math.remainder(b["yaw_rad"] - a["yaw_rad"], 2 * math.pi)
        assert abs(dyaw) <= math.radians(30.0) * dt + 1e-9            # turn-rate limit
        dv = math.hypot(b["vel_north_mps"] - a["vel_north_mps"], b["vel_east_mps"] - a["vel_east_mps"])
        assert dv <= 2.5 * dt + 1e-9                                  # acceleration limit
        if b["landed"]:
            assert b["speed_mps"] == 0.0 and b["up_m"] < 0.5      # no flight on the ground
    at = {round(r["t_s"] * MS): r for r in rows}
    north_leg = at[round(north_end / 100) * 100]
    assert north_leg["speed_mps"] == pytest.approx(5.0) and north_leg["yaw_rad"] == pytest.approx(0.0, abs=0.01)
    east_leg = at[round(east_end / 100) * 100]
    assert east_leg["yaw_rad"] == pytest.approx(math.pi / 2, abs=0.01)
    assert east_leg["speed_mps"] == pytest.approx(5.0)
    # NaN and an unsupported frame each stop the vehicle (2 s from 5 m/s, plus link latency),
    # well before GUID_TIMEOUT (3 s + 2 s of braking) would have
    for t_ms in (nan_ms, frame_ms):
        assert at[(round(t_ms / 100) - 5) * 100]["speed_mps"] == pytest.approx(5.0)
        assert at[(round(t_ms / 100) + 26) * 100]["speed_mps"] == 0.0
    # odometry drifts from truth only within the noise (Q) over this short flight
    last = rows[-1]
    assert math.hypot(last["odom_north_m"] - last["north_m"], last["odom_east_m"] - last["east_m"]) < 3.0


def test_observations_respect_fov_and_range(tmp_path):
    log_path = tmp_path / "truth.jsonl"
    stub = start_stub(tmp_path, "--speedup", "10", "--truth-log", str(log_path))
    conn = connect_tcp(stub.tcp_port)
    reports = []
    try:
        assert wait_heartbeat(conn) is not None
        arm_guided(conn)
        fly(conn, 5.0, 0.0, 20.0, collect=reports)
    finally:
        conn.close()
        assert stub.stop() == 0
    rows = {round(r["t_s"] * MS): r for r in read_truth_log(log_path)}
    reports3d = [m for m in reports if m.get_type() == "OBSTACLE_DISTANCE_3D"]
    assert len(reports3d) > 50
    by_time = {}
    for m in reports3d:
        assert m.frame == mavlink.MAV_FRAME_BODY_FRD and m.max_distance == 40.0 and m.z == 0.0
        row = rows[m.time_boot_ms]
        ob = next(o for o in row["obstacles"] if o["id"] == m.obstacle_id)
        dn, de = ob["north_m"] - row["north_m"], ob["east_m"] - row["east_m"]
        true_r = math.hypot(dn, de)
        true_b = math.remainder(math.atan2(de, dn) - row["yaw_rad"], 2 * math.pi)
        assert true_r <= 40.0 and abs(true_b) <= math.pi / 4
        assert math.hypot(m.x, m.y) == pytest.approx(true_r, abs=0.6)          # 6 sigma of R
        assert math.atan2(m.y, m.x) == pytest.approx(true_b, abs=math.radians(0.1))
        by_time.setdefault(m.time_boot_ms, set()).add(m.obstacle_id)
    # completeness (miss_probability 0): every obstacle in view at a frame time is reported
    t_lo, t_hi = min(by_time), max(by_time)
    checked = 0
    for t_ms, row in rows.items():
        if t_ms % 200 or not t_lo <= t_ms <= t_hi:
            continue
        for ob in row["obstacles"]:
            dn, de = ob["north_m"] - row["north_m"], ob["east_m"] - row["east_m"]
            b = math.remainder(math.atan2(de, dn) - row["yaw_rad"], 2 * math.pi)
            if math.hypot(dn, de) <= 40.0 and abs(b) <= math.pi / 4:
                assert ob["id"] in by_time.get(t_ms, set()), (t_ms, ob)
                checked += 1
    assert checked > 50


def test_params_commands_and_refusals_over_tcp(tmp_path):
    stub = start_stub(tmp_path, "--speedup", "5", "--streams-off", "--sysid", "3")
    conn = connect_tcp(stub.tcp_port)
    conn.target_system = 3
    try:
        hb = wait_heartbeat(conn)
        assert hb.get_srcSystem() == 3
        conn.mav.param_request_list_send(3, 1)
        values = {}
        first = wait_for(conn, lambda m: True, 5.0, "PARAM_VALUE")
        values[first.param_index] = first
        while len(values) < first.param_count:
            m = wait_for(conn, lambda m: True, 5.0, "PARAM_VALUE")
            assert m is not None, "param list incomplete"
            values[m.param_index] = m
        assert sorted(values) == list(range(first.param_count))
        assert values[0].param_id == "SYSID_THISMAV" and values[0].param_value == 3
        conn.mav.param_request_read_send(3, 1, b"GUID_TIMEOUT", -1)
        m = wait_for(conn, lambda m: m.param_id == "GUID_TIMEOUT", 5.0, "PARAM_VALUE")
        assert m.param_value == pytest.approx(3.0)
        conn.mav.param_set_send(3, 1, b"GUID_TIMEOUT", 1.5, mavlink.MAV_PARAM_TYPE_REAL32)
        m = wait_for(conn, lambda m: m.param_id == "GUID_TIMEOUT", 5.0, "PARAM_VALUE")
        assert m.param_value == pytest.approx(1.5)
        conn.mav.command_long_send(3, 1, mavlink.MAV_CMD_DO_MOTOR_TEST, 0, 0, 0, 0, 0, 0, 0, 0)
        ack = wait_for(conn, lambda m: m.command == mavlink.MAV_CMD_DO_MOTOR_TEST, 5.0, "COMMAND_ACK")
        assert ack.result == mavlink.MAV_RESULT_UNSUPPORTED
        conn.mav.command_long_send(3, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                   mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0)
        assert wait_for(conn, lambda m: True, 5.0, "AUTOPILOT_VERSION") is not None
        conn.mav.mission_request_list_send(3, 1)
        assert wait_for(conn, lambda m: True, 5.0, "MISSION_COUNT").count == 1   # home
        # streams off: nothing but heartbeats until asked
        assert wait_for(conn, lambda m: True, 1.0, "ATTITUDE") is None
        conn.mav.request_data_stream_send(3, 1, mavlink.MAV_DATA_STREAM_EXTRA1, 10, 1)
        assert wait_for(conn, lambda m: True, 5.0, "ATTITUDE") is not None
    finally:
        conn.close()
        assert stub.stop() == 0


def test_garbage_is_counted_and_several_clients_are_served(tmp_path):
    stub = start_stub(tmp_path, "--speedup", "5", "--udp", "127.0.0.1:0")
    tcp_a = connect_tcp(stub.tcp_port)
    tcp_b = connect_tcp(stub.tcp_port)
    udp = connect_udp(stub.udp_port)
    raw = socket.create_connection(("127.0.0.1", stub.tcp_port), timeout=5)
    try:
        raw.sendall(b"\x00garbage\xff" * 50 + bytes(range(256)))
        udp.write(b"this is not mavlink" * 10)
        udp.mav.heartbeat_send(6, 8, 0, 0, 0)          # registers the UDP client
        for conn in (tcp_a, tcp_b, udp):
            assert wait_heartbeat(conn) is not None
        udp.mav.param_request_read_send(1, 1, b"WPNAV_SPEED", -1)
        for conn in (tcp_a, tcp_b, udp):               # every client sees every reply
            m = wait_for(conn, lambda m: m.param_id == "WPNAV_SPEED", 5.0, "PARAM_VALUE")
            assert m is not None and m.param_value == 1000.0
    finally:
        for c in (tcp_a, tcp_b, udp):
            c.close()
        raw.close()
        assert stub.stop() == 0
    stats = [line for line in stub.stderr().splitlines() if "link statistics" in line][-1]
    bad = int(stats.split("bad_data=")[1].split(",")[0])
    assert bad >= 2, stats


def test_drop_rate_drops_about_that_fraction(tmp_path):
    stub = start_stub(tmp_path, "--speedup", "10", "--drop-rate", "0.5", "--seed", "2")
    conn = connect_tcp(stub.tcp_port)
    try:
        conn.mav.command_long_send(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 32, 100000,
                                   0, 0, 0, 0, 0)
        first = None
        count = 0
        while True:
            m = wait_for(conn, lambda m: True, 10.0, "LOCAL_POSITION_NED")
            assert m is not None
            if first is None:
                # the request itself may be dropped: resend until 10 Hz is in force
                conn.mav.command_long_send(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 32,
                                           100000, 0, 0, 0, 0, 0)
                ack = wait_for(conn, lambda a: a.command == 511, 2.0, "COMMAND_ACK")
                if ack is None:
                    continue
                first = wait_for(conn, lambda m: True, 5.0, "LOCAL_POSITION_NED").time_boot_ms
                continue
            count += 1
            if m.time_boot_ms >= first + 20000:
                break
    finally:
        conn.close()
        assert stub.stop() == 0
    # 200 messages sent at 10 Hz over 20 s; about half survive (binomial sd ~ 7)
    assert 60 <= count <= 140, count


def test_bad_scenario_exits_2_naming_file_and_key(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(PAPER.read_text().replace("dt_s: 0.1", "dt_s: fast"))
    proc = subprocess.run(stub_command("--scenario", str(bad), "--tcp", "127.0.0.1:0"),
                          capture_output=True, text=True, timeout=30)
    assert proc.returncode == 2
    assert str(bad) in proc.stderr and "vehicle.dt_s" in proc.stderr
    assert "expected a number" in proc.stderr and proc.stdout == ""


def test_port_in_use_exits_2(tmp_path):
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen(1)
        port = sock.getsockname()[1]
        proc = subprocess.run(stub_command("--scenario", str(PAPER), "--tcp", f"127.0.0.1:{port}"),
                              capture_output=True, text=True, timeout=30)
    assert proc.returncode == 2
    assert f"127.0.0.1:{port}" in proc.stderr and "in use" in proc.stderr


def test_sigterm_exits_0_and_flushes_truth_log(tmp_path):
    log_path = tmp_path / "truth.jsonl"
    stub = start_stub(tmp_path, "--speedup", "20", "--truth-log", str(log_path), "--tcp", "none",
                      "--udp", "127.0.0.1:0")
    assert stub.tcp_port is None and stub.udp_port is not None
    assert wait_until(lambda: log_path.exists() and log_path.stat().st_size > 0, 10.0)
    assert stub.stop() == 0
    rows = read_truth_log(log_path)     # every line complete JSON after the exit flush
    assert rows[-1]["t_s"] > 0 and rows[0]["mode"] == "STABILIZE"
    assert "clean shutdown" in stub.stderr()


def test_signing_signs_output_and_refuses_unsigned_commands(tmp_path):
    key = bytes(range(32))
    key_file = tmp_path / "key.hex"
    key_file.write_text(key.hex() + "\n")
    stub = start_stub(tmp_path, "--speedup", "5", "--signing-key", str(key_file))
    signed = connect_tcp(stub.tcp_port)
    signed.setup_signing(key, sign_outgoing=True)
    unsigned = connect_tcp(stub.tcp_port, source_system=254)
    try:
        hb = wait_heartbeat(signed)
        assert hb is not None and hb._signed        # verified with the key by the client
        unsigned.mav.param_request_read_send(1, 1, b"ANGLE_MAX", -1)
        assert wait_for(signed, lambda m: m.param_id == "ANGLE_MAX", 2.0, "PARAM_VALUE") is None
        signed.mav.param_request_read_send(1, 1, b"ANGLE_MAX", -1)
        m = wait_for(signed, lambda m: m.param_id == "ANGLE_MAX", 5.0, "PARAM_VALUE")
        assert m is not None and m._signed
    finally:
        signed.close()
        unsigned.close()
        assert stub.stop() == 0
    stats = [line for line in stub.stderr().splitlines() if "link statistics" in line][-1]
    assert int(stats.split("unsigned_rejected=")[1].split(",")[0]) >= 1, stats


def test_bad_signing_key_file_exits_2(tmp_path):
    key_file = tmp_path / "key.hex"
    key_file.write_text("abc\n")
    proc = subprocess.run(stub_command("--scenario", str(PAPER), "--tcp", "127.0.0.1:0",
                                       "--signing-key", str(key_file)),
                          capture_output=True, text=True, timeout=30)
    assert proc.returncode == 2 and "64 hex" in proc.stderr
