"""`sitl-stub --camera-only` as a real process on loopback UDP, with this test as its autopilot."""
import signal
import subprocess
import time

from .support import (PAPER, REPO, _read_line, mavlink, mavutil, stub_command, wait_for,
                      wait_heartbeat)

ORIGIN_LAT_DEG, ORIGIN_LON_DEG = -35.363261, 149.165230
EARTH_RADIUS_M = 6378137.0


def start_camera(tmp_path, *args):
    err = tmp_path / "camera.stderr"
    proc = subprocess.Popen(stub_command("--camera-only", "--scenario", str(PAPER), *args),
                            stdout=subprocess.PIPE, stderr=open(err, "w"), text=True, cwd=REPO)
    return proc, err


def test_camera_only_reports_obstacles_as_the_vehicles_component_100(tmp_path):
    proc, err = start_camera(tmp_path, "--connect", "udpin:127.0.0.1:0")
    try:
        line = _read_line(proc, 20.0)
        assert line.startswith("SITL_STUB CAMERA READY connect=udpin:127.0.0.1:"), err.read_text()
        port = int(line.rsplit(":", 1)[1])
        autopilot = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=3,
                                               source_component=1)
        autopilot.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR,
                                     mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 3)
        request = wait_for(autopilot, lambda m: m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                           10.0, "COMMAND_LONG")
        assert request is not None and request.get_srcSystem() == 3
        assert request.get_srcComponent() == 100 and request.target_system == 3
        # EKF origin 20 m north of the scenario's origin; the vehicle 20 m north of that
        lat = ORIGIN_LAT_DEG + 20.0 / EARTH_RADIUS_M * 57.29577951308232
        autopilot.mav.gps_global_origin_send(int(round(lat * 1e7)), int(ORIGIN_LON_DEG * 1e7),
                                             584000, 0)
        report = None
        deadline = time.monotonic() + 10.0
        t_ms = 5000
        while report is None and time.monotonic() < deadline:
            autopilot.mav.attitude_send(t_ms, 0, 0, 0, 0, 0, 0)
            autopilot.mav.local_position_ned_send(t_ms, 20.0, 0.0, -10.0, 0, 0, 0)
            report = wait_for(autopilot, lambda m: True, 0.1, "OBSTACLE_DISTANCE_3D")
            t_ms += 100
        assert report is not None, err.read_text()
        assert (report.get_srcSystem(), report.get_srcComponent()) == (3, 100)
        assert report.obstacle_id == 1 and abs(report.x - 20.0) < 0.5 and abs(report.y - 5.0) < 0.5
        assert 5000 <= report.time_boot_ms < t_ms
        assert wait_heartbeat(autopilot, 5.0, component=100).type == mavlink.MAV_TYPE_CAMERA
    finally:
        proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=10)
    assert code == 0
    assert "camera stopped" in err.read_text()


def test_camera_only_needs_a_link(tmp_path):
    proc, err = start_camera(tmp_path)
    assert proc.wait(timeout=30) == 2
    assert "--camera-only needs --connect URL" in err.read_text()
