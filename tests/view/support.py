"""A view (model, HTTP server, UDP feed listener) on loopback inside the test's event loop."""
from __future__ import annotations

import socket
from contextlib import asynccontextmanager

from companion.view import feed
from companion.view.model import ViewModel
from companion.view.server import start_server
from companion.view.sources import listen_feed


def state(seq: int, path=(), landmarks=(), movers=(), blocked=(), pose=(10.0, 2.0, 0.3)) -> dict:
    """A feed datagram's content, written out by hand."""
    return {
        "feed": feed.FEED_VERSION, "seq": seq, "t_s": 10.0 + seq, "vehicle": [1, 1],
        "armed": True, "guided": True, "phase": "airborne", "arrived": False, "safe_action": None,
        "goal_ne_m": [180.0, 0.0], "goal_radius_m": 2.0, "safety_distance_m": 10.0,
        "estimator": "ok", "radius_2sigma_m": 0.4,
        "pose": {"north_m": pose[0], "east_m": pose[1], "yaw_rad": pose[2],
                 "cov_m2": [0.04, 0.01, 0.09], "sigma_yaw_rad": 0.01},
        "path_ne_m": [list(p) for p in path],
        "landmarks": [{"id": i + 1, "north_m": n, "east_m": e, "cov_m2": [0.2, 0.05, 0.1]}
                      for i, (n, e) in enumerate(landmarks)],
        "movers": [{"track_id": i, "id": None, "north_m": n, "east_m": e, "vel_north_mps": vn,
                    "vel_east_mps": ve, "cov_m2": [0.3, 0.0, 0.3]}
                   for i, (n, e, vn, ve) in enumerate(movers)],
        "command": {"t_s": 10.0 + seq, "heading_rad": 0.5, "speed_mps": 4.0, "mode": "avoid"},
        "blocked": list(blocked), "sectors": feed.SECTORS, "setpoints": seq,
    }


class Sender:
    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.port = port

    def send(self, data: dict | bytes) -> None:
        raw = data if isinstance(data, bytes) else feed.encode(data)
        self.sock.sendto(raw, ("127.0.0.1", self.port))


@asynccontextmanager
async def running_view():
    """Yields (model, base URL, Sender to its feed port)."""
    model = ViewModel("test")
    runner, http_port = await start_server(model, "127.0.0.1", 0)
    transport, feed_port = await listen_feed(model, "127.0.0.1", 0)
    sender = Sender(feed_port)
    try:
        yield model, f"http://127.0.0.1:{http_port}", sender
    finally:
        sender.sock.close()
        transport.close()
        await runner.cleanup()
