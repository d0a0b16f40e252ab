"""The camera model: field of view, range, noise statistics R, misses and false alarms."""
import dataclasses
import math

import numpy as np
import pytest

from sitl_stub import camera
from sitl_stub.world import UINT16_MAX, load_scenario

from .support import PAPER

CFG = load_scenario(PAPER).sensor   # fov 90 deg, range 40 m, R = diag(0.1^2, (0.01 deg)^2)


def test_field_of_view_and_range():
    obstacles = [
        (1, 30.0, 0.0, 2.0),      # ahead, 30 m: seen
        (2, 10.0, 9.9, 2.0),      # bearing 44.7 deg: seen
        (3, 10.0, 10.2, 2.0),     # bearing 45.6 deg: outside the 90-deg FOV
        (4, 41.0, 0.0, 2.0),      # 41 m: beyond max range (centre range counts)
        (5, -10.0, 0.0, 2.0),     # behind
    ]
    cfg = dataclasses.replace(CFG, range_sigma_m=0.0, bearing_sigma_rad=0.0)
    dets = camera.observe(0.0, 0.0, 0.0, obstacles, cfg, np.random.default_rng(0))
    assert sorted(d.obstacle_id for d in dets) == [1, 2]
    d2 = next(d for d in dets if d.obstacle_id == 2)
    assert d2.range_m == pytest.approx(math.hypot(10.0, 9.9))
    assert d2.bearing_rad == pytest.approx(math.atan2(9.9, 10.0))
    assert d2.y_m > 0     # body FRD: an obstacle to the east of a north-facing vehicle is right


def test_bearing_is_relative_to_heading():
    cfg = dataclasses.replace(CFG, range_sigma_m=0.0, bearing_sigma_rad=0.0)
    # heading east; obstacle 20 m east and 5 m north -> 14 deg to the left
    dets = camera.observe(0.0, 0.0, math.pi / 2, [(7, 5.0, 20.0, 1.0)], cfg, np.random.default_rng(0))
    assert len(dets) == 1
    assert dets[0].bearing_rad == pytest.approx(-math.atan2(5.0, 20.0))
    assert dets[0].x_m == pytest.approx(20.0) and dets[0].y_m == pytest.approx(-5.0)


def test_noise_statistics_match_r():
    rng = np.random.default_rng(11)
    n = 4000
    true_r, true_b = camera.true_range_bearing(0.0, 0.0, 0.2, 20.0, 8.0)
    ranges, bearings = [], []
    for _ in range(n):
        (d,) = camera.observe(0.0, 0.0, 0.2, [(1, 20.0, 8.0, 2.0)], CFG, rng)
        ranges.append(d.range_m)
        bearings.append(d.bearing_rad)
    r_err = np.array(ranges) - true_r
    b_err = np.array(bearings) - true_b
    sr, sb = CFG.range_sigma_m, CFG.bearing_sigma_rad
    # mean within 4 standard errors, variance ratio within +-15% (~ 4.7 sigma for n = 4000)
    assert abs(r_err.mean()) < 4 * sr / math.sqrt(n)
    assert abs(b_err.mean()) < 4 * sb / math.sqrt(n)
    assert np.var(r_err, ddof=1) / sr**2 == pytest.approx(1.0, abs=0.15)
    assert np.var(b_err, ddof=1) / sb**2 == pytest.approx(1.0, abs=0.15)
    # the errors are independent
    assert abs(np.corrcoef(r_err, b_err)[0, 1]) < 4 / math.sqrt(n)


def test_ids_off_misses_and_false_alarms():
    cfg = dataclasses.replace(CFG, report_ids=False, miss_probability=0.3,
                              false_alarm_rate_hz=2.0)
    rng = np.random.default_rng(5)
    frames = 3000
    seen = false = 0
    for _ in range(frames):
        for d in camera.observe(0.0, 0.0, 0.0, [(1, 20.0, 0.0, 2.0)], cfg, rng):
            assert d.obstacle_id == UINT16_MAX
            if d.false_alarm:
                false += 1
                assert abs(d.bearing_rad) <= cfg.fov_rad / 2 and d.range_m <= cfg.max_range_m
            else:
                seen += 1
    assert seen / frames == pytest.approx(0.7, abs=0.04)
    lam = 2.0 / cfg.rate_hz * frames
    assert abs(false - lam) < 4 * math.sqrt(lam)


def test_sector_form_marks_the_obstacle_sectors():
    cfg = dataclasses.replace(CFG, range_sigma_m=0.0, bearing_sigma_rad=0.0)
    dets = camera.observe(0.0, 0.0, 0.0, [(1, 20.0, 0.0, 2.0)], cfg, np.random.default_rng(0))
    dist, inc_deg, offset_deg = camera.sector_distances_cm(dets, cfg)
    assert len(dist) == 72 and inc_deg == pytest.approx(1.25) and offset_deg == pytest.approx(-44.375)
    hit = [i for i, v in enumerate(dist) if v <= 4000]
    assert hit and all(v == 1800 for v in (dist[i] for i in hit))
    assert min(hit) < 36 <= max(hit)      # straddles straight ahead
    assert dist[0] == 4001 and dist[71] == 4001


def test_sector_bearing_is_the_bin_centre_as_the_companion_decodes_it():
    """A thin post 9.375 deg right of the nose, the centre of sector 43: decoded at 9.375 deg
    (ArduPilot reads element j at angle_offset + j * increment: angle_offset is element 0's centre)."""
    from companion.mavlink.codec import sector_bearings_rad   # the test may import both sides
    cfg = dataclasses.replace(CFG, range_sigma_m=0.0, bearing_sigma_rad=0.0)
    post = (1, 30.0 * math.cos(math.radians(9.375)), 30.0 * math.sin(math.radians(9.375)), 0.3)
    dets = camera.observe(0.0, 0.0, 0.0, [post], cfg, np.random.default_rng(0))
    dist, inc_deg, offset_deg = camera.sector_distances_cm(dets, cfg)
    bearings = sector_bearings_rad(0, inc_deg, offset_deg, len(dist))
    hit = [math.degrees(bearings[i]) for i, v in enumerate(dist) if v <= 4000]
    assert hit == pytest.approx([9.375])        # the sector's edge would say 8.75
    # every sector's centre is where the camera measured it: sector i spans
    # [-45 + 1.25 i, -45 + 1.25 (i + 1)], its centre -44.375 + 1.25 i
    assert [math.degrees(b) for b in bearings[:2]] == pytest.approx([-44.375, -43.125])


def test_ray_cast_sectors_see_the_nearest_surface_per_bin_and_a_wall_whole():
    cfg = dataclasses.replace(CFG, range_sigma_m=0.0, miss_probability=0.0,
                              false_alarm_rate_hz=0.0)
    near, far = (1, 20.0, 0.0, 2.0), (2, 30.0, 0.0, 4.0)        # the far one peeks out either side
    dist, inc_deg, offset_deg = camera.ray_cast_sectors_cm(0.0, 0.0, 0.0, [near, far], cfg,
                                                           np.random.default_rng(0))
    assert offset_deg == pytest.approx(-45.0 + 0.5 * inc_deg)
    assert 1800 <= dist[35] == dist[36] <= 1802                  # the bins either side of the nose
    flanks = [v for v in dist if 2500 < v < 4001]              # 5.7 to 7.7 deg off the nose
    assert len(flanks) >= 2 and all(2600 <= v <= 3000 for v in flanks)
    assert dist[0] == dist[71] == 4001
    wall = [(i, 25.0, e, 0.5) for i, e in enumerate(np.arange(-30.0, 30.01, 0.5))]
    dist, _, _ = camera.ray_cast_sectors_cm(0.0, 0.0, 0.0, wall, cfg, np.random.default_rng(0))
    assert all(v < 4001 for v in dist)                           # no gap along it


def test_ray_cast_sectors_miss_per_bin():
    cfg = dataclasses.replace(CFG, range_sigma_m=0.0, miss_probability=0.3,
                              false_alarm_rate_hz=0.0)
    wall = [(i, 25.0, e, 0.5) for i, e in enumerate(np.arange(-30.0, 30.01, 0.5))]
    rng = np.random.default_rng(4)
    empty = sum(v == 4001 for _ in range(50)
                for v in camera.ray_cast_sectors_cm(0.0, 0.0, 0.0, wall, cfg, rng)[0])
    assert empty / (50 * 72) == pytest.approx(0.3, abs=0.03)


def test_sensor_form_is_read_and_checked(tmp_path):
    text = open(PAPER).read().replace("sensor:", "sensor:\n  form: sectors", 1)
    path = tmp_path / "s.yaml"
    path.write_text(text)
    assert load_scenario(str(path)).sensor.form == "sectors"
    path.write_text(text.replace("form: sectors", "form: blobs"))
    with pytest.raises(Exception, match="sensor.form"):
        load_scenario(str(path))
