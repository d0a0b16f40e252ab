"""companion simulate's depth renderer (companion/sim/depth_render.py) against geometry worked
out by hand: a wall's depth, a post's angular width, the floor under a pitched camera, the side
an obstacle appears on, and Intel's stereo RMS error measured on rendered frames."""
import math

import numpy as np
import pytest

from companion.config.depth import DepthConfig
from companion.core import shapes
from companion.core.perception.depth_frame import CameraMount, DepthIntrinsics
from companion.core.perception.stereo_error import stereo_sigma_z_m
from companion.sim.depth_camera import TruePose, render_true_m, tilt_from_accel
from companion.sim.depth_render import (DepthRenderer, DepthScene, Prism, StereoErrors,
                                        occlusion_shadow, sensor_errors)

D455 = DepthConfig().intrinsics()
NO_ERRORS = StereoErrors.none()


def wall_ahead(distance_m: float, half_length_m: float = 50.0, height_m: float = 30.0) -> Prism:
    corners = np.array([[distance_m, -half_length_m], [distance_m + 0.3, -half_length_m],
                        [distance_m + 0.3, half_length_m], [distance_m, half_length_m]])
    return Prism(shapes.as_counter_clockwise(corners), 0.0, height_m)


def scene(posts=(), prisms=()) -> DepthScene:
    posts = np.array(posts, dtype=float).reshape(-1, 5)      # north, east, radius, base, top
    return DepthScene(posts[:, :2], posts[:, 2], posts[:, 3], posts[:, 4], tuple(prisms))


def test_a_wall_10_m_ahead_is_10_m_deep_on_every_pixel_it_covers():
    renderer = DepthRenderer(D455)
    true_m = render_true_m(renderer, scene(prisms=[wall_ahead(10.0)]), TruePose(0, 0, 5.0),
                           CameraMount())
    z16 = sensor_errors(true_m, D455, NO_ERRORS, np.random.default_rng(0))
    # the floor (5 m below) shows only below the row where a ray meets it within 10 m
    floor_row = D455.cy_px + D455.fy_px * 5.0 / 10.0
    wall = np.zeros(true_m.shape, dtype=bool)
    wall[:int(math.floor(floor_row)), :] = True
    assert np.abs(true_m[wall] - 10.0).max() < 1e-9
    assert (z16[wall] == 10000).all()
    assert (true_m[int(math.ceil(floor_row)):, :] < 10.0).all()    # the floor, nearer


def test_a_posts_angular_width_is_2_asin_r_over_d():
    intr = DepthIntrinsics.from_fov(2001, 101, 60.0, 10.0, 0.1, 60.0)     # fine columns
    renderer = DepthRenderer(intr)
    for r, d in ((1.0, 10.0), (0.3, 7.0), (2.0, 30.0)):
        true_m = render_true_m(renderer, scene(posts=[(d, 0.0, r, 0.0, math.inf)]),
                               TruePose(0, 0, 50.0), CameraMount())
        row = true_m[50]
        cols = np.flatnonzero(np.isfinite(row))
        bearings = np.arctan((cols - intr.cx_px) / intr.fx_px)
        pixel_rad = 1.0 / intr.fx_px
        width = bearings.max() - bearings.min()
        assert abs(width - 2.0 * math.asin(r / d)) <= 2.0 * pixel_rad
        assert row[int(intr.cx_px)] == pytest.approx(d - r, abs=1e-9)


def test_the_ground_row_of_a_pitched_camera_is_where_trigonometry_puts_it():
    renderer = DepthRenderer(D455)
    alt, pitch = 3.0, math.radians(-20.0)
    true_m = render_true_m(renderer, DepthScene.empty(), TruePose(0, 0, alt),
                           CameraMount(pitch_rad=pitch))
    col = true_m[:, int(D455.cx_px)]
    y = (np.arange(D455.height_px) - D455.cy_px) / D455.fy_px
    down = math.sin(-pitch) + math.cos(pitch) * y            # a ray's down component, body
    horizon_row = D455.cy_px - D455.fy_px * math.tan(-pitch)
    sees = down > 0.0
    reach = sees & (alt / np.where(sees, down, 1.0) * np.sqrt(1 + y * y) <= 1e6)
    assert np.allclose(col[reach], alt / down[reach], rtol=1e-12)
    assert np.isinf(col[np.arange(D455.height_px) < horizon_row - 0.5]).all()
    assert np.isfinite(col[np.arange(D455.height_px) > horizon_row + 0.5]).all()


def test_an_obstacle_to_the_right_appears_right_of_centre_and_a_roll_tilts_it():
    renderer = DepthRenderer(D455)
    world = scene(posts=[(10.0, 3.0, 0.5, 0.0, math.inf)])
    level = render_true_m(renderer, world, TruePose(0, 0, 20.0), CameraMount())
    cols = np.flatnonzero(np.isfinite(level[int(D455.cy_px)]))
    assert cols.min() > D455.cx_px
    # rolled right (right wing down), the post leans left in the image: nearer the centre
    # at the top of the image than at the bottom
    rolled = render_true_m(renderer, world, TruePose(0, 0, 20.0, roll_rad=0.3), CameraMount())
    top_cols = np.flatnonzero(rolled[40] < 15.0)             # the post (the floor is farther)
    low_cols = np.flatnonzero(rolled[440] < 15.0)
    assert len(top_cols) and len(low_cols)
    assert top_cols.mean() < low_cols.mean()


def test_accelerating_forward_pitches_the_nose_down_by_atan_a_over_g():
    roll, pitch = tilt_from_accel((2.0, 0.0, 0.0), 0.0)
    assert pitch == pytest.approx(-math.atan(2.0 / 9.80665)) and roll == pytest.approx(0.0)
    roll, pitch = tilt_from_accel((0.0, 2.0, 0.0), 0.0)       # east, facing north: right
    assert roll > 0.0 and pitch == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("distance_m", [2.0, 4.0])
def test_noise_on_the_measured_rms_is_intels_model_within_15_percent(distance_m):
    renderer = DepthRenderer(D455)
    true_m = render_true_m(renderer, scene(prisms=[wall_ahead(distance_m)]), TruePose(0, 0, 10.0),
                           CameraMount())
    errors = StereoErrors(depth_noise=True, edge_shadow=False, dropout_fraction=0.0)
    rng = np.random.default_rng(3)
    centre = (slice(100, 380), slice(200, 648))
    residuals = [sensor_errors(true_m, D455, errors, rng)[centre] * 0.001 - distance_m
                 for _ in range(10)]
    rms = float(np.sqrt(np.mean(np.square(residuals))))
    model = float(stereo_sigma_z_m(distance_m, D455.fx_px, 0.095, 0.08))
    assert abs(rms - model) <= 0.15 * model, (rms, model)
    # correlated: neighbours within a patch share their offset
    frame = sensor_errors(true_m, D455, errors, rng)
    assert (frame[0:6, 0:6] == frame[0, 0]).all() or np.ptp(frame[0:6, 0:6]) <= 1


def test_the_occlusion_shadow_lies_left_of_a_near_edge_and_is_as_wide_as_the_disparity_step():
    depth = np.full((1, 100), 10.0)
    depth[0, 50:70] = 2.0
    fx, b = 400.0, 0.1
    shadow = occlusion_shadow(depth, fx, b)[0]
    band = fx * b * (1.0 / 2.0 - 1.0 / 10.0)                 # 16 px
    hidden = np.flatnonzero(shadow[10:]) + 10                 # (not the image's left band)
    assert 50 - band <= hidden.min() <= 50 - band + 1 and hidden.max() == 49
    assert not shadow[50:].any()
    fixed = occlusion_shadow(depth, fx, b, band_px=5)[0]
    assert np.flatnonzero(fixed).tolist() == [45, 46, 47, 48, 49]


def test_the_errors_switch_off_one_by_one_and_share_one_random_stream():
    renderer = DepthRenderer(D455)
    true_m = render_true_m(renderer, scene(posts=[(6.0, 0.0, 0.5, 0.0, math.inf)]),
                           TruePose(0, 0, 2.0), CameraMount())
    clean = sensor_errors(true_m, D455, NO_ERRORS, np.random.default_rng(1))
    holes_only = sensor_errors(true_m, D455, StereoErrors(depth_noise=False, edge_shadow=False,
                                                          dropout_fraction=0.1),
                               np.random.default_rng(1))
    both = sensor_errors(true_m, D455, StereoErrors(depth_noise=True, edge_shadow=False,
                                                    dropout_fraction=0.1),
                         np.random.default_rng(1))
    inside = (true_m > 1.0) & (true_m < 15.0)                 # noise cannot leave the span here
    assert ((holes_only == 0) == (both == 0))[inside].all()   # the same holes, noise or not
    dropped = (holes_only == 0) & (clean > 0)
    assert 0.05 < dropped.sum() / (clean > 0).sum() < 0.15
    assert ((holes_only == clean) | (holes_only == 0)).all()
