"""The companion's depth perception on synthetic frames (tests/core/depth_scenes.py): a wall ahead,
a post on one side (left stays left), the floor of a pitched camera removed and counted, a low
wall's top and a tall post's clipped top, a hole pixel that blanks nothing, a tilted vehicle."""
import math

import numpy as np
import pytest

from companion.core.estimation.range_noise import stereo_k_per_m
from companion.core.perception.blobs import SurfacePoint
from companion.core.perception.depth_frame import CameraMount, DepthFrame
from companion.core.perception.depth_perception import DepthPerceptionParams, perceive
from companion.core.perception.depth_points import (decimate_nearest, decimated_intrinsics,
                                                    level_points)
from companion.core.perception.floor import fit_floor

from tests.core.depth_scenes import D455, Cylinder, Panel, bearing_deg, render

PARAMS = DepthPerceptionParams()
LOOK_DOWN = CameraMount(pitch_rad=math.radians(-20.0))


def test_a_wall_ten_metres_ahead_is_a_chain_at_ten_metres_across_the_view():
    frame = render([Panel(10.0, -30.0, 10.0, 30.0)], floor=False)
    got = perceive(frame, CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    assert got.posts == []
    assert len(got.observations) >= 3
    assert all(isinstance(o, SurfacePoint) for o in got.observations)
    for obs in got.observations:     # 10 m / cos(bearing), less up to half a bin's slant
        assert obs.range_m * math.cos(obs.bearing_rad) == pytest.approx(10.0, abs=0.1)
    bearings = [math.degrees(o.bearing_rad) for o in got.observations]
    assert min(bearings) < -40.0 and max(bearings) > 40.0


def test_a_post_on_the_right_is_reported_on_the_right_with_its_centre_and_radius():
    post = Cylinder(12.0, 4.0, 0.5)
    got = perceive(render([post]), CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    assert len(got.posts) == 1
    seen = got.posts[0]
    assert math.degrees(seen.bearing_rad) == pytest.approx(bearing_deg(12.0, 4.0), abs=1.0)
    assert seen.bearing_rad > 0.0                                  # right is positive
    assert seen.range_m == pytest.approx(math.hypot(12.0, 4.0), abs=0.4)
    assert seen.radius_m == pytest.approx(0.5, abs=0.3)
    mirrored = perceive(render([Cylinder(12.0, -4.0, 0.5)]), CameraMount(), 0.0, 0.0, 5.0,
                        PARAMS)
    assert mirrored.posts[0].bearing_rad == pytest.approx(-seen.bearing_rad, abs=1e-6)


def test_a_pitched_camera_sees_only_floor_in_an_empty_world_and_maps_none_of_it():
    frame = render([], altitude_m=5.0, mount=LOOK_DOWN)
    got = perceive(frame, LOOK_DOWN, 0.0, 0.0, 5.0, PARAMS)
    assert got.floor_points > 1000 and got.obstacle_points == 0
    assert got.observations == []


def test_without_an_altitude_the_floor_is_a_fitted_plane_at_the_vehicles_height():
    frame = render([Cylinder(9.0, 0.0, 0.4)], altitude_m=4.0, mount=LOOK_DOWN)
    got = perceive(frame, LOOK_DOWN, 0.0, 0.0, None, PARAMS)
    assert got.plane is not None and got.plane.c == pytest.approx(4.0, abs=0.05)
    assert got.floor_points > 1000
    assert len(got.posts) == 1 and got.posts[0].bearing_rad == pytest.approx(0.0, abs=0.02)


def test_a_floor_plane_is_refused_among_points_that_hold_none():
    wall = level_points(render([Panel(6.0, -9.0, 6.0, 9.0)], floor=False).depth, D455,
                        CameraMount(), 0.0, 0.0)
    assert fit_floor(wall.xyz_m, 0.5) is None


def test_a_low_wall_keeps_its_top_and_a_tall_posts_top_is_cut_by_the_image_edge():
    low = perceive(render([Panel(8.0, -3.0, 8.0, 3.0, top_m=1.5)]), CameraMount(), 0.0, 0.0,
                   5.0, PARAMS)
    assert low.observations
    for obs in low.observations:
        assert 5.0 - obs.top_down_m == pytest.approx(1.5, abs=0.1)
        assert not obs.top_clipped
    tall = perceive(render([Cylinder(8.0, 0.0, 0.5, top_m=40.0)]), CameraMount(), 0.0, 0.0,
                    5.0, PARAMS)
    assert len(tall.posts) == 1 and tall.posts[0].top_clipped
    assert tall.observations[0].top_clipped


def test_a_hole_pixel_blanks_no_direction():
    frame = render([Cylinder(10.0, 0.0, 0.3)])
    holed = frame.depth.copy()
    holed[:, 424] = 0                                    # a whole column of holes on the post
    holed[::7, 420:428] = 0
    before = perceive(frame, CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    after = perceive(DepthFrame(2, 0, 0, D455, holed), CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    assert np.array_equal(np.isfinite(before.binned.ranges_m), np.isfinite(after.binned.ranges_m))
    assert len(after.posts) == 1
    assert after.posts[0].range_m == pytest.approx(before.posts[0].range_m, abs=0.05)


def test_a_rolled_and_pitched_vehicle_levels_its_points():
    roll, pitch = math.radians(12.0), math.radians(-8.0)
    frame = render([Cylinder(10.0, -3.0, 0.5, top_m=3.0)], altitude_m=5.0, roll_rad=roll,
                   pitch_rad=pitch)
    got = perceive(frame, CameraMount(), roll, pitch, 5.0, PARAMS)
    assert got.floor_points > 0
    assert len(got.posts) == 1
    post = got.posts[0]
    assert math.degrees(post.bearing_rad) == pytest.approx(bearing_deg(10.0, -3.0), abs=1.0)
    assert 5.0 - post.top_down_m == pytest.approx(3.0, abs=0.15)
    assert post.bottom_down_m > 5.0 - 1.0           # down to the floor's band ...
    assert got.observations[0].bottom_down_m == 5.0   # ... so it stands on the floor


def test_a_mount_yawed_right_sees_a_post_on_the_right():
    right = CameraMount(yaw_rad=math.radians(90.0))
    got = perceive(render([Cylinder(0.0, 8.0, 0.5)], mount=right), right, 0.0, 0.0, 5.0, PARAMS)
    assert len(got.posts) == 1
    assert math.degrees(got.posts[0].bearing_rad) == pytest.approx(90.0, abs=1.0)


def test_the_range_noise_is_the_stereo_models():
    blobs = PARAMS.blob_params(D455.fx_px)
    k = stereo_k_per_m(0.08, D455.fx_px, 0.095)
    assert blobs.range_sigma_k_per_m == pytest.approx(k)
    assert 0.0285 < k * 4.0 ** 2 < 0.031       # ALGORITHM-NOTES: ~30 mm at 4 m on a D455
    post = perceive(render([Cylinder(15.0, 0.0, 0.5)]), CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    near = perceive(render([Cylinder(5.0, 0.0, 0.5)]), CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    assert post.observations[0].meas_cov[0][0] > 4.0 * near.observations[0].meas_cov[0][0]


def test_decimation_keeps_each_blocks_nearest_valid_pixel():
    depth = np.array([[0, 900, 0, 0], [1200, 0, 0, 0]], dtype=np.uint16)
    assert decimate_nearest(depth, 2).tolist() == [[900, 0]]
    intr = decimated_intrinsics(D455, 4)
    assert intr.width_px == 212 and intr.height_px == 120
    assert intr.hfov_rad == pytest.approx(D455.hfov_rad, rel=0.01)


def test_a_frame_used_after_the_vehicle_moved_is_seen_from_where_it_is_now():
    from companion.core.perception.depth_perception import MotionSince
    frame = render([Cylinder(12.0, 0.0, 0.5)])
    motion = MotionSince(forward_m=2.0, right_m=0.0, yaw_rad=math.radians(-10.0))
    got = perceive(frame, CameraMount(), 0.0, 0.0, 5.0, PARAMS, motion)
    post = got.posts[0]
    assert post.range_m == pytest.approx(10.0, abs=0.4)
    assert math.degrees(post.bearing_rad) == pytest.approx(10.0, abs=1.0)  # turned left: now right


def test_a_stray_patch_above_a_low_wall_does_not_lift_its_top():
    frame = render([Panel(8.0, -3.0, 8.0, 3.0, top_m=1.5)])
    pixels = frame.depth.copy()
    pixels[196:204, 416:432] = 8000          # a false match at the wall's range, 5 m up
    got = perceive(DepthFrame(2, 0, 0, D455, pixels), CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    assert got.observations
    for obs in got.observations:
        assert 5.0 - obs.top_down_m == pytest.approx(1.5, abs=0.1)


def test_the_bins_span_what_the_mount_lets_the_camera_see():
    from companion.core.perception.depth_points import view_span
    centre, span = view_span(D455, CameraMount())
    assert centre == pytest.approx(0.0, abs=1e-9)
    assert span == pytest.approx(D455.hfov_rad, rel=0.01)
    _, pitched = view_span(D455, LOOK_DOWN)
    assert pitched > span                           # the lower corners reach wider
    on_side = CameraMount(roll_rad=math.radians(90.0))
    assert view_span(D455, on_side)[1] == pytest.approx(D455.vfov_rad, rel=0.02)
    assert view_span(D455, CameraMount(pitch_rad=math.radians(-90.0)))[1] == pytest.approx(
        2.0 * math.pi)


def test_a_camera_on_its_side_sees_a_post_on_the_right_on_the_right():
    on_side = CameraMount(roll_rad=math.radians(90.0))
    got = perceive(render([Cylinder(10.0, 3.0, 0.4)], mount=on_side), on_side, 0.0, 0.0, 5.0,
                   PARAMS)
    assert len(got.posts) == 1
    assert math.degrees(got.posts[0].bearing_rad) == pytest.approx(bearing_deg(10.0, 3.0),
                                                                   abs=1.0)


def test_a_trunk_half_hidden_by_a_nearer_one_is_surface_spread_over_its_own_width():
    # A 0.2 m trunk at 15 m just behind the left edge of a nearer 0.3 m trunk: its visible part
    # is a compact blob cut by the nearer one (no centre from its width), given as surface
    # points. Each is spread over the trunk's own width (under a metre), not a wall's 4 m
    # spacing: a landmark made from it must not swallow the trees around it (forest worlds: a
    # 2.3 m sigma made every trunk within 5 m 'ambiguous' until it was 5 m away, issue 44).
    near = Cylinder(8.0, 0.0, 0.3)
    edge = math.atan2(0.3, 8.0)
    far = Cylinder(15.0 * math.cos(edge), -15.0 * math.sin(edge) - 0.15, 0.2)
    got = perceive(render([near, far]), CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    behind = [o for o in got.observations if o.range_m > 12.0]
    assert behind and all(isinstance(o, SurfacePoint) for o in behind)
    for obs in behind:
        assert math.sqrt(obs.meas_cov[0][0]) < 1.0
    assert any(not isinstance(o, SurfacePoint) and o.range_m < 9.0 for o in got.observations)


def test_a_post_near_the_max_depth_is_dropped():
    # D455 here: 20 m max depth, range sigma at 20 m 0.81 m: posts beyond 18.4 m are dropped
    # (their pixels' far noise tail is cut at 20 m: a centre biased short).
    near, far = Cylinder(15.0, -3.0, 0.3), Cylinder(19.0, 4.0, 0.3)
    got = perceive(render([near, far]), CameraMount(), 0.0, 0.0, 5.0, PARAMS)
    assert [round(p.range_m) for p in got.posts] == [15]
    kept = perceive(render([near, far]), CameraMount(), 0.0, 0.0, 5.0,
                    DepthPerceptionParams(far_sigmas=0.0))
    assert len(kept.posts) == 2 and max(p.range_m for p in kept.posts) > 18.4
