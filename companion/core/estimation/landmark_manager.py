"""The landmark manager: each camera frame's observations into the map.

Per frame: the floor's points and bad heights dropped (perception/vertical_extent.py), the
frame's joint association (association.py), then each observation updates a landmark, a mover
track, or starts a landmark (with its probation, probation.py); then the lifecycle deletes and
expires landmarks (lifecycle.py) and the bounded map archives those left behind (map_archive.py).
Id-less landmarks get internal negative ids (never published).
"""
from __future__ import annotations

import numpy as np

from companion.core.estimation.association import associate_frame
from companion.core.estimation.estimator import Estimator
from companion.core.estimation.lifecycle import Lifecycle, expected_visible
from companion.core.estimation.map_archive import MapArchive, stale
from companion.core.estimation.probation import SIGHTING_ACTIONS, MoverProbation
from companion.core.estimation.range_noise import with_range_model
from companion.core.estimation.slam_types import Observation, UpdateReport
from companion.core.geometry import place
from companion.core.perception.blobs import SurfacePoint
from companion.core.perception.surface_cover import covering_nis
from companion.core.perception.vertical_extent import (ExtentParams, PointHeights, VerticalExtent,
                                                       classify, in_vertical_view)


class LandmarkManager:
    """Landmark creation, update, merging into moved ones, deletion and archiving."""

    def __init__(self, estimator: Estimator, probation: MoverProbation, lifecycle: Lifecycle,
                 extent: ExtentParams | None) -> None:
        options = estimator.options
        self.estimator = estimator
        self.probation = probation
        self.lifecycle = lifecycle
        self._next_anonymous_id = -1
        self._frame_hits: set[int] = set()      # landmark keys detected in the current frame
        self._frame_near: set[int] = set()      # ... come near by an ambiguous observation
        self._frame_added: set[int] = set()
        self._frame_taken: set[int] = set()     # ... planned for update by the frame's association
        # the bounded map (off unless configured): landmarks left behind, marginalised out
        self.archive = MapArchive(options.archive) if options.archive is not None else None
        self._last_seen: dict[int, float] = {}   # landmark key: last detection (archive only)
        self.extent_params = extent
        self.extents: dict = {}                 # landmark key -> VerticalExtent
        self.points = {"ground": 0, "bad_z": 0}

    def observe(self, observations: list[Observation]) -> list[UpdateReport]:
        """One camera frame: static landmarks update the SLAM state, movers only their tracks.

        A landmark seen for the first time is on probation (probation.py): its observations
        correct only itself (a Schmidt update, never the pose or other landmarks) until it is
        judged static; a mover is marginalised out of the map and tracked.
        """
        est = self.estimator
        used: set[int] = set()
        reports = []
        self._frame_hits, self._frame_near, self._frame_added = set(), set(), set()
        noise = est.slam.noise
        observations, heights = self._heights(observations)
        observations = with_range_model(observations, noise.range_sigma_m,
                                        est.options.range_sigma_k_per_m, noise.bearing_sigma_rad)
        anonymous = [obs for obs in observations if obs.obstacle_id is None]
        ids = est.slam.landmark_ids()
        plans = {id(obs): (p.action, ids[p.index] if p.index is not None else None)
                 for obs, p in zip(anonymous, associate_frame(
                     est.slam, np.array([[o.range_m, o.bearing_rad] for o in anonymous]),
                     meas_covs=[o.meas_cov_array() for o in anonymous]))}
        self._frame_taken = {key for action, key in plans.values() if action == "update"}
        for obs, height in zip(observations, heights):
            report = self._observe_one(obs, used, plans.get(id(obs)))
            if report.action in ("updated", "added") and report.landmark_index is not None:
                used.add(report.landmark_index)
                self._note_extent(report, height)
            reports.append(report)
        reports.extend(self.probation.judge())
        reports.extend(self._judge_lifecycle())
        if self.archive is not None:
            reports.extend(self._bound_map())
        return reports

    def _heights(self, observations: list[Observation]) -> tuple[list, list]:
        """The observations that may become landmarks, and their heights (None: no z): the
        floor's points and those with a bad z dropped and counted."""
        altitude_m = self.estimator.altitude_m
        if self.extent_params is None or altitude_m is None:
            return list(observations), [None] * len(observations)
        kept, heights = [], []
        for obs in observations:
            verdict = classify(obs.top_down_m, obs.bottom_down_m, obs.range_m, altitude_m,
                               self.extent_params, obs.top_clipped, obs.bottom_clipped)
            if verdict == "ground":
                self.points["ground"] += 1
                continue
            if verdict == "bad":
                self.points["bad_z"] += 1
                continue
            kept.append(obs)
            heights.append(verdict)
        return kept, heights

    def _note_extent(self, report: UpdateReport, heights: PointHeights | None) -> None:
        if heights is None or report.action not in ("updated", "added") \
                or report.landmark_index is None:
            return
        key = self.estimator.slam.landmark_ids()[report.landmark_index]
        if key is not None:
            self.extents.setdefault(key, VerticalExtent()).update(heights)

    def _bound_map(self) -> list[UpdateReport]:
        """The bounded map (core/estimation/map_archive.py): this frame's new landmarks take the
        place of the archived ones they are; landmarks (not tentative) behind, far and unseen
        leave the filter (marginalised: their rows and columns deleted) for the archive."""
        slam, archive, clock_s = self.estimator.slam, self.archive, self.estimator.clock_s
        keys = slam.landmark_ids()
        for key in self._frame_hits | self._frame_added:
            self._last_seen[key] = clock_s
        if self._frame_added and len(archive):
            index_of = {key: i for i, key in enumerate(keys)}
            covs = slam.landmark_covs()
            points = slam.landmarks()
            for key in self._frame_added:
                if key in index_of:
                    archive.reacquire(key, points[index_of[key]], covs[index_of[key]])
        old = stale(slam.pose, slam.landmarks(), np.array([self._last_seen.get(k, clock_s)
                                                           for k in keys]), clock_s,
                    archive.params)
        # tentatives are left to the lifecycle; a landmark still on probation for motion is
        # archived too (seen too few times at the view's edge, many never leave probation)
        drop = [i for i in np.flatnonzero(old).tolist() if not self.lifecycle.is_tentative(keys[i])]
        if not drop:
            return []
        points, covs = slam.landmarks(), slam.landmark_covs()
        reports = []
        for i in drop:
            key = keys[i]
            archive.add(key, points[i], covs[i], self._last_seen.pop(key, clock_s), clock_s)
            self.lifecycle.forget(key)
            self.probation.drop(key)
            reports.append(UpdateReport("archived", None, None, None, key))
        slam.remove_landmarks(drop)
        return reports

    def _schmidt(self, key) -> bool:
        """Whether a landmark's observations correct only itself: on probation for motion, or
        tentative (a landmark not yet confirmed never corrects the pose)."""
        return key in self.probation.young or self.lifecycle.is_tentative(key)

    def _born(self, key: int) -> None:
        self.probation.start(key)
        self.lifecycle.add(key, self.estimator.clock_s)
        self._frame_added.add(key)

    def _judge_lifecycle(self) -> list[UpdateReport]:
        """Count this frame's chance for every landmark; remove (marginalise) the deleted and
        the expired ones."""
        est = self.estimator
        slam = est.slam
        keys = slam.landmark_ids()
        visible = expected_visible(slam.pose, slam.landmarks(), self.lifecycle.params)
        if self.extents and est.altitude_m is not None:
            # a landmark whose extent lies wholly above or below the vertical view is not missed
            ranges = np.hypot(*(slam.landmarks() - slam.pose[:2]).T)
            visible = visible & np.array([
                key not in self.extents or in_vertical_view(
                    self.extents[key], float(r), est.altitude_m, self.extent_params)
                for key, r in zip(keys, ranges)], dtype=bool).reshape(visible.shape)
        verdict = self.lifecycle.judge(est.clock_s, keys, visible, self._frame_hits,
                                       self._frame_near, self._frame_added)
        reports = []
        for action, removed in (("deleted", verdict.deleted), ("expired", verdict.expired)):
            for key in removed:
                slam.remove_landmark(slam.landmark_ids().index(key))
                self.probation.drop(key)
                reports.append(UpdateReport(action, None, None, None, key))
        return reports

    def _observe_one(self, obs: Observation, used: set[int], plan=None) -> UpdateReport:
        est, oid, probation = self.estimator, obs.obstacle_id, self.probation
        if oid is None:
            return self._observe_anonymous(obs, used, plan)
        if oid in probation.movers.by_obstacle_id:
            return probation.update_mover(probation.movers.by_obstacle_id[oid], obs)
        young = self._schmidt(oid)
        report = est.slam.update(obs, exclude=used, landmark_only=young)
        if not young and report.action in ("updated", "outlier"):
            est.monitor.add(est.clock_s, report.nis, 2)
        if report.action == "added":
            self._born(oid)
        self._note(oid, obs, report.action)
        return probation.judge_refusal(oid, obs, report, used)

    def _observe_anonymous(self, obs: Observation, used: set[int], plan=None) -> UpdateReport:
        """An observation without an id: the frame's joint association first (``plan``, from
        core/estimation/association.py: (action, landmark key)), then a young landmark that may
        have moved (a gate as wide as a mover's top speed allows; with ``moved_beyond_own_gate``
        not the one an ambiguous sighting came near), then the mover tracks, then a new landmark
        unless it was ambiguous."""
        slam, probation = self.estimator.slam, self.probation
        z = np.array([obs.range_m, obs.bearing_rad])
        action, key = plan if plan is not None else ("new", None)
        ids = slam.landmark_ids()
        if action == "ambiguous" and self.estimator.options.new_beside_tentative \
                and key in ids and key not in self._frame_taken and self.lifecycle.is_tentative(key):
            action = "new"      # near only a tentative landmark nothing else took: a guess
        if isinstance(obs, SurfacePoint):
            return self._observe_surface(obs, z, key if action == "update" else None)
        if action == "update" and key in ids:
            return self._update_landmark(key, ids.index(key), z, obs)
        taken = self._frame_taken
        if action == "ambiguous" and self.estimator.options.moved_beyond_own_gate:
            taken = taken | {key}     # seen near where it is mapped: no sign that it moved
        moved = probation.moved(place(probation.young_pose(), z), self._frame_hits, taken)
        if moved is not None:
            self._relocate(moved, z, obs, used)
            self._note(moved, obs, "moved")
            return UpdateReport("moved", None, None, None, None)
        if len(probation.movers):
            point, cov = probation.world_point(obs)
            track = probation.movers.nearest(self.estimator.clock_s, point, cov,
                                             probation.track_reach(point))
            if track is not None:
                return probation.update_mover(track, obs)
        if action == "new":
            # New against the map the frame began with; one born from this frame's own earlier
            # observation may be what this one sees (two returns of one post): ambiguous then.
            nis, _ = slam.nis_all(z, obs.meas_cov_array())
            near = [i for i in range(len(nis)) if ids[i] in self._frame_added]
            if near and float(np.min(nis[near])) <= slam.gates.new_landmark_nis:
                action, key = "ambiguous", ids[near[int(np.argmin(nis[near]))]]
        if action == "ambiguous":
            # Never an update: the landmark it gated on is another observation's this frame.
            if key in ids:
                self._frame_near.add(key)
                return UpdateReport("ambiguous", ids.index(key), None, None, None)
            return UpdateReport("ambiguous", None, None, None, None)
        if action == "new":
            return self._add_anonymous(z, obs)
        report = slam.update(obs, exclude=used)
        if report.action == "added":
            self._name_anonymous(report, obs)
        return report

    def _observe_surface(self, obs: SurfacePoint, z: np.ndarray, paired: int | None) -> UpdateReport:
        """A wall's or a face's chain point: it updates the landmark the frame's association
        paired it with (``paired``, a key) if that landmark covers it
        (core/perception/surface_cover.py); else it is ambiguous if another one covers it, and
        surface the map does not hold yet (a new landmark) if none does. Never a young landmark
        'moved' there (a wall does not move; its chain points fall elsewhere along it every
        frame) and never a mover's."""
        slam = self.estimator.slam
        ids = slam.landmark_ids()
        if ids:
            pose = slam.pose
            nis = covering_nis(slam.landmarks() - pose[:2], z, np.asarray(obs.own_cov, dtype=float),
                               float(pose[2]), float(slam.pose_cov[2, 2]), 0.5 * obs.stretch_m)
            covers = nis <= slam.gates.accept_nis
            if paired in ids and covers[ids.index(paired)]:
                return self._update_landmark(paired, ids.index(paired), z, obs)
            if covers.any():
                best = int(np.argmin(nis))
                self._frame_near.add(ids[best])
                return UpdateReport("ambiguous", best, None, float(nis[best]), None)
        return self._add_anonymous(z, obs)

    def _update_landmark(self, key: int, index: int, z: np.ndarray,
                         obs: Observation) -> UpdateReport:
        """Update the id-less landmark ``key`` (state index ``index``) the association chose;
        a young or tentative one corrects only itself and is left out of the monitor."""
        est = self.estimator
        young = self._schmidt(key)
        report = est.slam.update_landmark(z, index, landmark_only=young,
                                          meas_cov=obs.meas_cov_array(),
                                          range_modelled=obs.range_modelled)
        if not young:
            est.monitor.add(est.clock_s, report.nis, 2)
        self._note(key, obs, report.action)
        return report

    def _add_anonymous(self, z: np.ndarray, obs: Observation) -> UpdateReport:
        report = self.estimator.slam.add_landmark(z, None, obs.meas_cov_array())
        self._name_anonymous(report, obs)
        return report

    def _name_anonymous(self, report: UpdateReport, obs: Observation) -> None:
        """A landmark just added without an id gets the next internal negative one (never
        published) and starts its probation."""
        key = self._next_anonymous_id
        self._next_anonymous_id -= 1
        self.estimator.slam.set_landmark_id(report.landmark_index, key)
        self._born(key)
        self._note(key, obs, "added")

    def _note(self, key: int, obs: Observation, action: str) -> None:
        """A report of ``action`` on landmark ``key``: detected this frame if it saw it, and a
        sighting of a landmark on probation."""
        if action in SIGHTING_ACTIONS:
            self._frame_hits.add(key)
        self.probation.sight(key, obs, action)

    def _relocate(self, key: int, z: np.ndarray, obs: Observation, used: set[int]) -> None:
        """A young landmark's object was seen where it has moved to: the landmark restarts there
        (marginalised and added again under its key; on probation it never corrected the pose,
        so nothing else learnt from where it was). A false alarm born beside a post that takes
        the post's first sightings so stands on the post, not where the false alarm was, and
        the post's next sightings update it; a mover is mapped where it is until demoted."""
        slam = self.estimator.slam
        index = slam.landmark_ids().index(key)
        slam.remove_landmark(index)
        shifted = {i - 1 if i > index else i for i in used if i != index}
        used.clear()
        used.update(shifted)
        report = slam.add_landmark(z, None, obs.meas_cov_array())
        slam.set_landmark_id(report.landmark_index, key)
        used.add(report.landmark_index)
