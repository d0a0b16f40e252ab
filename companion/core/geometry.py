"""The 2D kinematic models (the paper's unicycle, the multicopter) and the range-bearing model,
with their Jacobians.

Frame: MAVLink LOCAL_NED. ``x`` is metres north, ``y`` metres east, ``psi`` the yaw in radians,
clockwise from north. A bearing is measured from the vehicle's heading, positive to the right
(the BODY_FRD convention: ``bearing = atan2(y_frd, x_frd)``).

Pure functions of numpy arrays; no I/O, no clocks.
"""
from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi


def wrap_angle(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (angle_rad + math.pi) % TWO_PI - math.pi


def wrap_angles(angles_rad: np.ndarray) -> np.ndarray:
    """Vectorised :func:`wrap_angle`."""
    return (np.asarray(angles_rad) + math.pi) % TWO_PI - math.pi


def move(pose: np.ndarray, speed_mps: float, heading_change_rad: float, dt_s: float) -> np.ndarray:
    """The paper's motion model f(Xv, u): turn by ``heading_change_rad`` then fly ``speed*dt``.

    pose: (3,) [north_m, east_m, yaw_rad]. Returns a new (3,) pose, yaw wrapped.
    """
    course = pose[2] + heading_change_rad
    step_m = speed_mps * dt_s
    return np.array([pose[0] + step_m * math.cos(course),
                     pose[1] + step_m * math.sin(course),
                     wrap_angle(course)])


def move_jacobians(pose: np.ndarray, speed_mps: float, heading_change_rad: float,
                   dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`move`: (3,3) with respect to the pose, (3,2) to the control [v, gamma]."""
    course = pose[2] + heading_change_rad
    c, s = math.cos(course), math.sin(course)
    step_m = speed_mps * dt_s
    jac_pose = np.array([[1.0, 0.0, -step_m * s],
                         [0.0, 1.0, step_m * c],
                         [0.0, 0.0, 1.0]])
    jac_control = np.array([[dt_s * c, -step_m * s],
                            [dt_s * s, step_m * c],
                            [0.0, 1.0]])
    return jac_pose, jac_control


def move_velocity(pose: np.ndarray, vel_north_mps: float, vel_east_mps: float,
                  yaw_rate_rad_s: float, dt_s: float) -> np.ndarray:
    """The multicopter model: fly the NED velocity the autopilot reports, turn at its yaw rate.

    Course and yaw are independent (hover, sideways flight, crabbing). pose: (3,)
    [north_m, east_m, yaw_rad]; returns a new (3,) pose, yaw wrapped.
    """
    return np.array([pose[0] + vel_north_mps * dt_s, pose[1] + vel_east_mps * dt_s,
                     wrap_angle(pose[2] + yaw_rate_rad_s * dt_s)])


def move_velocity_jacobians(pose: np.ndarray, vel_north_mps: float, vel_east_mps: float,
                            yaw_rate_rad_s: float, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`move_velocity`: (3,3) to the pose (the identity: the motion does not
    depend on the pose, which is what makes the filter's predict O(1)), (3,3) to the control
    [vel_north, vel_east, yaw_rate] (dt on the diagonal)."""
    return np.eye(3), np.eye(3) * dt_s


def observe(pose: np.ndarray, landmark: np.ndarray) -> np.ndarray:
    """Range-bearing observation h(Xv, m): (2,) [range_m, bearing_rad], bearing wrapped."""
    d_north = landmark[0] - pose[0]
    d_east = landmark[1] - pose[1]
    return np.array([math.hypot(d_north, d_east),
                     wrap_angle(math.atan2(d_east, d_north) - pose[2])])


def observe_jacobians(pose: np.ndarray, landmark: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`observe`: (2,3) with respect to the pose, (2,2) to the landmark."""
    d_north = landmark[0] - pose[0]
    d_east = landmark[1] - pose[1]
    range_sq = d_north * d_north + d_east * d_east
    range_m = math.sqrt(range_sq)
    jac_landmark = np.array([[d_north / range_m, d_east / range_m],
                             [-d_east / range_sq, d_north / range_sq]])
    jac_pose = np.empty((2, 3))
    jac_pose[:, :2] = -jac_landmark
    jac_pose[:, 2] = (0.0, -1.0)
    return jac_pose, jac_landmark


def place(pose: np.ndarray, measurement: np.ndarray) -> np.ndarray:
    """Inverse observation g(Xv, z): the landmark position (2,) seen at [range_m, bearing_rad]."""
    direction = pose[2] + measurement[1]
    return np.array([pose[0] + measurement[0] * math.cos(direction),
                     pose[1] + measurement[0] * math.sin(direction)])


def place_jacobians(pose: np.ndarray, measurement: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of :func:`place`: (2,3) with respect to the pose, (2,2) to the measurement."""
    direction = pose[2] + measurement[1]
    c, s = math.cos(direction), math.sin(direction)
    r = measurement[0]
    jac_pose = np.array([[1.0, 0.0, -r * s],
                         [0.0, 1.0, r * c]])
    jac_measurement = np.array([[c, -r * s],
                                [s, r * c]])
    return jac_pose, jac_measurement


def is_visible(range_m: float, bearing_rad: float, fov_rad: float, max_range_m: float,
               view_yaws_rad: tuple[float, ...] = (0.0,)) -> bool:
    """True when a point at (range, bearing) lies inside the sensor's field of view and range.
    ``view_yaws_rad``: a rig of cameras of that view each, by their yaw on the body (0: forward);
    the point is visible to any of them."""
    return 0.0 < range_m <= max_range_m and \
        view_offset_rad(bearing_rad, view_yaws_rad) <= 0.5 * fov_rad


def view_offset_rad(bearing_rad: float, view_yaws_rad: tuple[float, ...] = (0.0,)) -> float:
    """How far (rad, >= 0) a body bearing lies from the nearest camera's axis of a rig
    (``view_yaws_rad``, each camera's yaw on the body). The one forward camera: |bearing|, as
    it always was (the same bits)."""
    if view_yaws_rad == (0.0,):
        return abs(bearing_rad)
    return min(abs(wrap_angle(bearing_rad - yaw)) for yaw in view_yaws_rad)


def view_offsets_rad(bearings_rad: np.ndarray,
                     view_yaws_rad: tuple[float, ...] = (0.0,)) -> np.ndarray:
    """Vectorised :func:`view_offset_rad`: (n,) bearings (rad) to (n,) offsets."""
    if view_yaws_rad == (0.0,):
        return np.abs(bearings_rad)
    return np.min([np.abs(wrap_angles(np.asarray(bearings_rad) - yaw))
                   for yaw in view_yaws_rad], axis=0)
