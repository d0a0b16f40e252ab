"""Held out: random worlds (posts with bases and tops, walls, buildings, the floor) seen from
random tilted poses and mounts, rendered by companion/sim/depth_render.py and by an independent
scalar ray caster written here (one pixel at a time: faces as vertical rectangles and caps as
polygons, unit rays, elementary rotations), noise off: the same depth wherever either sees."""
import math

import numpy as np
import pytest

from companion.core import shapes
from companion.core.perception.depth_frame import CameraMount, DepthIntrinsics
from companion.sim.depth_camera import TruePose, render_true_m
from companion.sim.depth_render import DepthRenderer, DepthScene, Prism


def rot_x(a):
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def rot_y(a):
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def rot_z(a):
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def inside_polygon(p, poly) -> bool:
    """Even-odd rule (any polygon)."""
    x, y = p
    inside = False
    for i in range(len(poly)):
        (x0, y0), (x1, y1) = poly[i], poly[(i + 1) % len(poly)]
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


def range_to_post(o, u, c, r, base, top) -> float:
    best = math.inf
    horiz = math.hypot(u[0], u[1])
    if horiz > 1e-12:
        h = (u[0] / horiz, u[1] / horiz)
        w = (c[0] - o[0], c[1] - o[1])
        along = w[0] * h[0] + w[1] * h[1]
        miss2 = w[0] ** 2 + w[1] ** 2 - along ** 2
        if miss2 <= r * r and w[0] ** 2 + w[1] ** 2 > r * r:
            s = along - math.sqrt(r * r - miss2)            # horizontal distance to the side
            if s > 0:
                dist = s / horiz
                z = o[2] + dist * u[2]                      # altitude of the hit (u[2] is up)
                if base <= z <= top:
                    best = dist
    for level in (top, base):
        if math.isfinite(level) and level > 0 and abs(u[2]) > 1e-12:
            dist = (level - o[2]) / u[2]
            if dist > 0:
                p = (o[0] + dist * u[0] - c[0], o[1] + dist * u[1] - c[1])
                if p[0] ** 2 + p[1] ** 2 <= r * r:
                    best = min(best, dist)
    return best


def range_to_prism(o, u, corners, base, top) -> float:
    best = math.inf
    n = len(corners)
    for i in range(n):
        a, b = corners[i], corners[(i + 1) % n]
        # the face's vertical plane: points a + s (b - a) + z up; solve o + d u = that
        e = (b[0] - a[0], b[1] - a[1])
        det = -u[0] * e[1] + u[1] * e[0]
        if abs(det) < 1e-15:
            continue
        rx, ry = a[0] - o[0], a[1] - o[1]
        dist = (-rx * e[1] + ry * e[0]) / det
        s = (u[0] * ry - u[1] * rx) / det
        if dist > 0 and 0 <= s <= 1:
            z = o[2] + dist * u[2]
            if base <= z <= top:
                best = min(best, dist)
    for level in (top, base):
        if math.isfinite(level) and level > 0 and abs(u[2]) > 1e-12:
            dist = (level - o[2]) / u[2]
            if dist > 0 and inside_polygon((o[0] + dist * u[0], o[1] + dist * u[1]), corners):
                best = min(best, dist)
    return best


def scalar_depth(intr, pose, mount, posts, prisms) -> np.ndarray:
    """Per pixel: the unit ray in north-east-up, the nearest range, depth = range x cos(off-axis)."""
    body_to_ned = rot_z(pose.yaw_rad) @ rot_y(pose.pitch_rad) @ rot_x(pose.roll_rad)
    cam_to_body = rot_z(mount.yaw_rad) @ rot_y(mount.pitch_rad) @ rot_x(mount.roll_rad)
    ned_to_neu = np.diag([1.0, 1.0, -1.0])
    origin = ned_to_neu @ (np.array([pose.north_m, pose.east_m, -pose.alt_m])
                           + body_to_ned @ np.array(mount.offset_frd_m))
    axis = ned_to_neu @ body_to_ned @ cam_to_body @ np.array([1.0, 0.0, 0.0])
    out = np.full((intr.height_px, intr.width_px), np.inf)
    for v in range(intr.height_px):
        for col in range(intr.width_px):
            # a pixel's ray in the camera's own forward-right-down axes
            frd = np.array([1.0, (col - intr.cx_px) / intr.fx_px, (v - intr.cy_px) / intr.fy_px])
            u = ned_to_neu @ body_to_ned @ cam_to_body @ (frd / np.linalg.norm(frd))
            best = origin[2] / -u[2] if u[2] < 0 and origin[2] > 0 else math.inf
            for c_n, c_e, r, base, top in posts:
                best = min(best, range_to_post(origin, u, (c_n, c_e), r, base, top))
            for corners, base, top in prisms:
                best = min(best, range_to_prism(origin, u, corners, base, top))
            out[v, col] = best * float(u @ axis)
    return out


def random_world(rng):
    posts = [(rng.uniform(4, 25), rng.uniform(-12, 12), rng.uniform(0.2, 2.0),
              rng.choice([0.0, rng.uniform(1, 4)]), rng.choice([math.inf, rng.uniform(5, 15)]))
             for _ in range(int(rng.integers(3, 8)))]
    prisms = []
    for _ in range(int(rng.integers(1, 4))):
        centre = np.array([rng.uniform(6, 25), rng.uniform(-15, 15)])
        angle = rng.uniform(0, math.pi)
        k = int(rng.integers(3, 7))
        radii = rng.uniform(1.0, 4.0)
        corners = np.array([centre + radii * np.array([math.cos(angle + 2 * math.pi * i / k),
                                                       math.sin(angle + 2 * math.pi * i / k)])
                            for i in range(k)])
        base = float(rng.choice([0.0, rng.uniform(0.5, 3.0)]))
        prisms.append((shapes.as_counter_clockwise(corners), base,
                       float(rng.choice([math.inf, base + rng.uniform(2, 12)]))))
    return posts, prisms


@pytest.mark.parametrize("seed", [101, 202, 303])
def test_random_worlds_match_an_independent_scalar_ray_caster(seed):
    rng = np.random.default_rng(seed)
    intr = DepthIntrinsics.from_fov(40, 30, 90.0, 70.0, 0.1, 40.0)
    posts, prisms = random_world(rng)
    pose = TruePose(0.0, 0.0, float(rng.uniform(1.0, 8.0)), float(rng.uniform(-0.3, 0.3)),
                    float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.4, 0.4)))
    mount = CameraMount((0.2, 0.05, -0.1), float(rng.uniform(-0.2, 0.2)),
                        float(rng.uniform(-0.5, 0.1)), float(rng.uniform(-0.3, 0.3)))
    arr = np.array(posts, dtype=float).reshape(-1, 5)
    scene = DepthScene(arr[:, :2], arr[:, 2], arr[:, 3], arr[:, 4],
                       tuple(Prism(c, b, t) for c, b, t in prisms))
    fast = render_true_m(DepthRenderer(intr), scene, pose, mount)
    slow = scalar_depth(intr, pose, mount, posts, prisms)
    near = (slow <= intr.max_depth_m) | (fast <= intr.max_depth_m)
    assert near.sum() > 0.3 * near.size                       # the world is in view
    # (a pixel whose ray grazes a silhouette may differ; allow a few)
    same = np.isclose(fast, slow, rtol=0.0, atol=1e-6)
    assert (~same & near).sum() <= 2, np.argwhere(~same & near)
