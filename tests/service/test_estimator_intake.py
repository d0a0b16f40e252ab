"""The service's estimator intake: GPS_RAW_INT / EKF_STATUS_REPORT decoding, when the autopilot's
position is fused, ODOMETRY's quality, and the estimator's notices."""
import dataclasses
import math

import pytest

from companion.mavlink import codec
from companion.mavlink.dialect import mavlink
from companion.onboard.odometry_intake import PositionHealth
from companion.onboard.pipeline import Pipeline, snapshot
from tests.adapters.test_codec import roundtrip
from tests.service.test_pipeline import GOAL, Feed, config, hb

GOOD_FLAGS = (mavlink.ESTIMATOR_ATTITUDE | mavlink.ESTIMATOR_VELOCITY_HORIZ
              | mavlink.ESTIMATOR_POS_HORIZ_REL | mavlink.ESTIMATOR_POS_HORIZ_ABS)


def gps_raw(fix_type=3, eph=90, h_acc_mm=0):
    return mavlink.MAVLink_gps_raw_int_message(0, fix_type, -353632610, 1491652300, 584000, eph,
                                              120, 0, 0, 12, 0, h_acc_mm, 0, 0, 0, 0)


def ekf_status(flags=GOOD_FLAGS):
    return mavlink.MAVLink_ekf_status_report_message(flags, 0.1, 0.1, 0.1, 0.1, 0.0, 0.0)


def test_gps_raw_int_and_ekf_status_report_decode_through_real_bytes():
    fix = codec.decode(roundtrip(gps_raw(eph=90, h_acc_mm=1500)))
    assert fix == codec.GpsFix(1, 1, 3, 0.9, 1.5, 12)
    unknown = codec.decode(roundtrip(gps_raw(eph=65535, h_acc_mm=0)))
    assert unknown.hdop is None and unknown.h_acc_m is None
    status = codec.decode(roundtrip(ekf_status()))
    assert status.flags == GOOD_FLAGS and status.horizontal_position_ok
    for bad in (mavlink.ESTIMATOR_CONST_POS_MODE, mavlink.ESTIMATOR_GPS_GLITCH):
        assert not codec.decode(roundtrip(ekf_status(GOOD_FLAGS | bad))).horizontal_position_ok
    assert not codec.decode(roundtrip(ekf_status(GOOD_FLAGS & ~16))).horizontal_position_ok


def health(fusion="auto", **keys):
    est = dataclasses.replace(config().estimator, position_fusion=fusion, **keys)
    return PositionHealth(est)


def test_auto_fuses_only_a_fresh_healthy_3d_fix_with_a_good_ekf():
    h = health(position_sigma_m=None)
    assert h.sigma_m(10.0) is None                                   # nothing heard yet
    h.note(codec.GpsFix(1, 1, 3, 0.9, 1.5, 12), 10.0)
    assert h.sigma_m(10.0) is None                                   # no EKF status yet
    h.note(codec.EkfStatus(1, 1, GOOD_FLAGS), 10.0)
    assert h.sigma_m(10.5) == pytest.approx(1.5)                     # h_acc
    assert h.sigma_m(12.5) is None                                   # stale (2 s)
    h.note(codec.GpsFix(1, 1, 2, 0.9, None, 12), 12.5)
    h.note(codec.EkfStatus(1, 1, GOOD_FLAGS), 12.5)
    assert h.sigma_m(12.5) is None                                   # a 2D fix
    h.note(codec.GpsFix(1, 1, 3, 3.5, None, 12), 12.6)
    assert h.sigma_m(12.6) is None                                   # HDOP 3.5 > 2
    h.note(codec.GpsFix(1, 1, 3, 1.2, None, 12), 12.7)
    assert h.sigma_m(12.7) == pytest.approx(1.2)                     # HDOP x 1 m
    h.note(codec.EkfStatus(1, 1, GOOD_FLAGS | mavlink.ESTIMATOR_GPS_GLITCH), 12.8)
    assert h.sigma_m(12.8) is None
    assert health("on", position_sigma_m=2.0).sigma_m(0.0) == 2.0    # on: always
    off = health("off")
    off.note(codec.GpsFix(1, 1, 3, 0.9, 1.5, 12), 0.0)
    off.note(codec.EkfStatus(1, 1, GOOD_FLAGS), 0.0)
    assert off.sigma_m(0.0) is None                                  # off: never


def feed_with(fusion: str, sigma_m: float = 0.5):
    base = config(require_camera=False)
    cfg = dataclasses.replace(base, estimator=dataclasses.replace(
        base.estimator, position_fusion=fusion, position_sigma_m=sigma_m))
    feed = Feed(Pipeline(cfg, GOAL, record_track=True))
    feed.send(hb())
    return feed


@pytest.mark.parametrize("fusion", ["auto", "off"])
def test_a_healthy_autopilot_position_pulls_the_pose_only_when_fused(fusion):
    feed = feed_with(fusion, sigma_m=0.1)
    for _ in range(300):      # the velocity says 5 m/s, the vehicle flies 5.05: 1.5 m in 30 s
        feed.send(codec.decode(roundtrip(gps_raw())))
        feed.send(codec.decode(roundtrip(ekf_status())))
        feed.north_m += 0.005
        feed.step()
    nav = feed.p.navigator
    gap = abs(nav.slam.pose[0] - feed.north_m)
    if fusion == "auto":
        assert nav.position_fixes == {"fused": 30, "refused": 0} and gap < 0.5
    else:
        assert nav.position_fixes == {"fused": 0, "refused": 0} and gap > 1.4
    assert snapshot(feed.p)["position_fixes"] == nav.position_fixes


def test_odometry_quality_and_notices_follow_the_estimator_state():
    feed = feed_with("off")
    for _ in range(4):
        feed.step()
    poses = [o for o in feed.outputs if isinstance(o, codec.PoseEstimate)]
    assert poses and poses[-1].quality == 100
    assert roundtrip(codec.odometry(poses[-1]), 1, 191).quality == 100
    nav = feed.p.navigator
    nav.slam._cov_buf[0, 0] = 30.0 ** 2                         # 2-sigma 60 m: lost
    out = []
    for _ in range(10):
        out += feed.step()
    notices = [o for o in out if isinstance(o, codec.Notice)]
    assert [n.text for n in notices] == ["companion: estimator lost: pose 2-sigma 60.0 m"]
    assert notices[0].severity == codec.SEVERITY_ERROR
    poses = [o for o in out if isinstance(o, codec.PoseEstimate)]
    assert poses[-1].quality == -1
    sps = [o for o in out if isinstance(o, codec.VelocitySetpoint)]
    assert sps and all(sp.vel_north_mps == 0.0 and sp.reason == "hold: estimator lost"
                       for sp in sps)
    report = snapshot(feed.p)
    assert report["estimator_state"] == "lost"
    assert [c["state"] for c in report["estimator_state_changes"]] == ["ok", "lost"]


def test_an_uncertain_arrival_is_said_once_and_not_declared():
    feed = feed_with("off")
    feed.north_m = 176.5
    feed.step(speed_mps=2.0)
    feed.p.navigator.slam._cov_buf[0, 0] = 1.5 ** 2               # 2-sigma 3 m > 2 m
    out = []
    for _ in range(10):
        out += feed.step(speed_mps=2.0)
    texts = [o.text for o in out if isinstance(o, codec.Notice)]
    assert texts.count("companion: arrival uncertain (+-3.0 m)") == 1
    assert "companion: goal reached" not in texts and not snapshot(feed.p)["arrived"]
    assert math.isclose(
        [o for o in out if isinstance(o, codec.VelocitySetpoint)][-1].vel_north_mps, 0.0)


@pytest.mark.parametrize("line, message", [
    ("  motion_model: velocity_ned", "estimator.motion_model: expected one of paper, velocity_ned, got 'unicycle'"),
    ("  position_fusion: auto", "estimator.position_fusion: expected one of auto, on, off, got 'unicycle'"),
])
def test_estimator_keys_are_checked_with_file_and_key(tmp_path, line, message):
    from companion.config.service import load_config
    from companion.errors import ConfigError
    text = open("config/companion.yaml").read()
    key = line.split(":")[0]
    assert line in text
    path = tmp_path / "c.yaml"
    path.write_text(text.replace(line, f"{key}: unicycle"))
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(info.value) == f"{path}: {message}"


def test_a_bare_yaml_off_means_position_fusion_off(tmp_path):
    """YAML 1.1 reads a bare `off` as false: the key still means the word."""
    from companion.config.service import load_config
    path = tmp_path / "c.yaml"
    path.write_text(open("config/companion.yaml").read().replace(
        "  position_fusion: auto", "  position_fusion: off"))
    assert load_config(path).estimator.position_fusion == "off"


def test_the_paper_keeps_its_model_and_the_service_defaults_to_the_multicopter():
    from companion.config.scenario import load_scenario
    from companion.config.sections import EstimatorConfig
    from companion.config.service import load_config
    assert load_scenario("config/scenarios/paper.yaml").estimator_config().motion_model == "paper"
    assert load_scenario("config/scenarios/paper.yaml").estimator_config().position_fusion == "off"
    assert load_scenario("config/scenarios/copter.yaml").estimator_config().motion_model \
        == "velocity_ned"
    assert load_config("config/companion.yaml").estimator.motion_model == "velocity_ned"
    assert EstimatorConfig(range_sigma_m=0.1, bearing_sigma_deg=0.01).motion_model == "velocity_ned"


def test_a_refused_autopilot_position_is_logged_once_then_counted_every_ten_seconds(caplog):
    base = config(require_camera=False)
    cfg = dataclasses.replace(base, estimator=dataclasses.replace(
        base.estimator, position_fusion="on", position_sigma_m=0.5,
        position_reset_after_s=None))                              # refused for ever
    feed = Feed(Pipeline(cfg, GOAL))
    feed.send(hb())
    for _ in range(50):
        feed.step()
    assert feed.p.navigator.position_fixes["refused"] == 0
    with caplog.at_level("WARNING", logger="companion.onboard.odometry_intake"):
        for _ in range(600):            # 60 s of fixes 30 m off the estimate: one a second
            feed.north_m += 30.0
            feed.step()
            feed.north_m -= 30.0
    refused = feed.p.navigator.position_fixes["refused"]
    lines = [r.getMessage() for r in caplog.records if "position refused" in r.getMessage()]
    assert refused >= 55 and feed.p.position_health.refusals.total == refused
    assert 6 <= len(lines) <= 7, lines            # at once, then once per 10 s of vehicle time
    assert "refused:" in lines[0] and "times in 10 s" in lines[1]
    said = [int(line.split("refused ")[1].split(" times")[0]) for line in lines[1:]]
    assert 1 + sum(said) <= refused and all(8 <= n <= 11 for n in said)
    assert f"({1 + sum(said)} in all)" in lines[-1]


def test_the_throttled_warning_says_it_again_after_the_period_or_a_reboot():
    from companion.onboard.odometry_intake import ThrottledWarning
    w = ThrottledWarning(period_s=10.0)
    assert [w.note(t) for t in (0.0, 1.0, 9.9, 10.0, 10.5)] == [1, None, None, 3, None]
    assert w.note(2.0) == 2 and w.total == 6           # vehicle time went back: said at once
