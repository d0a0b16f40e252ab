"""What the view shows, accumulated from the feed and the truth log: no I/O here.

The feed carries the latest picture and the estimated path since its previous datagram; the model
keeps the whole path (thinned) so a browser that connects mid-flight sees it all. A new flight
(the feed's sequence or vehicle time going back) starts a new path; so does a truth log that was
truncated or replaced.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

MAX_PATH_POINTS = 20_000          # per path; beyond, every other point is dropped (thinned)
MIN_STEP_M = 0.25                 # points closer than this to the previous one are not kept


@dataclass
class Path:
    """A growing polyline; ``epoch`` changes when it starts over, ``base`` when it is thinned."""
    points: list = field(default_factory=list)
    epoch: int = 0

    def extend(self, points) -> None:
        for north, east in points:
            if not (math.isfinite(north) and math.isfinite(east)):
                continue
            if self.points:
                last = self.points[-1]
                if math.hypot(north - last[0], east - last[1]) < MIN_STEP_M:
                    continue
            self.points.append([north, east])
        if len(self.points) > MAX_PATH_POINTS:
            self.points = self.points[::2]
            self.epoch += 1           # indices changed: clients take the whole path again

    def restart(self) -> None:
        self.points = []
        self.epoch += 1


class ViewModel:
    """Latest feed state, both paths, the true obstacles, and counters; ``version`` grows on
    every change (the stream sends when it moved)."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.state: dict | None = None
        self.estimated = Path()
        self.true = Path()
        self.true_obstacles: list[dict] = []
        self.true_shapes: list[dict] = []  # walls and buildings: the truth log's first line
        self.true_pose: dict | None = None
        self.datagrams = 0
        self.refused = 0
        self.last_refusal: str | None = None
        self.flights = 0
        self.version = 0
        self.finished = False          # a replay source that reached the end of its file

    def on_feed(self, state: dict) -> None:
        previous = self.state
        if previous is None or state["seq"] < previous["seq"] or _went_back(previous, state):
            self.estimated.restart()
            self.flights += 1
        self.state = state
        self.datagrams += 1
        self.estimated.extend(state["path_ne_m"])
        pose = state.get("pose")
        if pose:
            self.estimated.extend([[pose["north_m"], pose["east_m"]]])
        self.version += 1

    def on_refused(self, reason: str) -> None:
        self.refused += 1
        self.last_refusal = reason
        self.version += 1

    def on_truth(self, records: list[dict], restarted: bool = False) -> None:
        """Records of the stub's truth log (north_m, east_m, yaw_rad, obstacles)."""
        if restarted:
            self.true.restart()
            self.true_shapes = []
        for record in records:
            if isinstance(record.get("shapes"), list):
                self.true_shapes = [s for s in (_shape(raw) for raw in record["shapes"]) if s]
        usable = [r for r in records if isinstance(r.get("north_m"), (int, float))
                  and isinstance(r.get("east_m"), (int, float))]
        if not usable and not restarted:
            return
        if usable:
            self.true.extend([[r["north_m"], r["east_m"]] for r in usable])
            last = usable[-1]
            self.true_pose = {"north_m": last["north_m"], "east_m": last["east_m"],
                              "yaw_rad": last.get("yaw_rad"), "t_s": last.get("t_s")}
            if isinstance(last.get("obstacles"), list):
                self.true_obstacles = [
                    {"id": o.get("id"), "north_m": o["north_m"], "east_m": o["east_m"],
                     "radius_m": o.get("radius_m", 0.0)}
                    for o in last["obstacles"] if "north_m" in o and "east_m" in o]
        self.version += 1

    def summary(self) -> dict:
        return {"source": self.source, "datagrams": self.datagrams, "refused": self.refused,
                "last_refusal": self.last_refusal, "flights": self.flights,
                "finished": self.finished, "version": self.version}

    def full(self) -> dict:
        """Everything, paths whole (GET /api/state and a stream's first event)."""
        return {"state": self.state, "info": self.summary(),
                "estimated_path": self._path(self.estimated, 0),
                "true_path": self._path(self.true, 0),
                "true_obstacles": self.true_obstacles, "true_shapes": self.true_shapes,
                "true_pose": self.true_pose}

    def delta(self, sent: dict) -> dict:
        """What a stream client lacks; ``sent`` ({'estimated': (epoch, n), 'true': ...}) is
        updated in place."""
        out = {"state": self.state, "info": self.summary(),
               "true_obstacles": self.true_obstacles, "true_shapes": self.true_shapes,
               "true_pose": self.true_pose}
        for name, path in (("estimated", self.estimated), ("true", self.true)):
            epoch, count = sent.get(name, (None, 0))
            start = count if epoch == path.epoch else 0
            out[f"{name}_path"] = self._path(path, start)
            sent[name] = (path.epoch, len(path.points))
        return out

    @staticmethod
    def _path(path: Path, start: int) -> dict:
        return {"epoch": path.epoch, "from": start, "points": path.points[start:]}


def _shape(raw) -> dict | None:
    """A wall or building of the truth log as the page draws it; None if it is not one."""
    if not isinstance(raw, dict) or not isinstance(raw.get("outline"), list):
        return None
    outline = []
    for point in raw["outline"]:
        if not (isinstance(point, list) and len(point) == 2
                and all(isinstance(v, (int, float)) and math.isfinite(v) for v in point)):
            return None
        outline.append([float(point[0]), float(point[1])])
    if len(outline) < 3:
        return None
    return {"id": raw.get("id"), "kind": str(raw.get("kind", "")), "outline": outline}


def _went_back(previous: dict, state: dict) -> bool:
    before, now = previous.get("t_s"), state.get("t_s")
    return isinstance(before, (int, float)) and isinstance(now, (int, float)) and now < before - 1.0
