"""Finding unknown objects in lidar scans: what is not in the known map and is small enough to be an object.

Per scan: hit points (world frame) that fall inside a known map box (grown by ``map_margin``) or lie on the floor
are dropped; the rest are split into clusters of neighbouring rays; a cluster no wider than ``max_size`` is an
object sighting. Its centre is fitted as a circle of the known ``object_radius`` (Gauss-Newton on the distances of
the points from the centre). Sightings are associated with tracks by distance; a track seen in ``confirm_scans``
scans is *found*, and logged once. Nothing here knows body ids or true positions: the input is the scan alone.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from pydantic import Field

from robokit.config import Schema
from robokit.msgs.mobile import LaserScan


class DiscoveryConfig(Schema):
    """Object discovery parameters (lengths in m).

    Attributes:
        object_radius: Radius of the objects looked for (upright cylinders or spheres).
        max_size: Widest cluster still taken for an object.
        min_points: Fewest scan points in a sighting.
        cluster_gap: Neighbouring points farther apart than this start a new cluster.
        detect_range: Points farther than this are not used for discovery.
        map_margin: Points this close to a known map box belong to the map.
        ground_height: Points lower than this (world z) are floor returns.
        associate: A sighting this close to a track is that track.
        confirm_scans: Sightings needed before an object counts as found.
    """

    object_radius: float = Field(0.05, gt=0)
    max_size: float = Field(0.25, gt=0)
    min_points: int = Field(2, ge=1)
    cluster_gap: float = Field(0.1, gt=0)
    detect_range: float = Field(3.5, gt=0)
    map_margin: float = Field(0.08, ge=0)
    ground_height: float = Field(0.03, ge=0)
    associate: float = Field(0.3, gt=0)
    confirm_scans: int = Field(3, ge=1)


@dataclass
class Track:
    """One object candidate: estimated centre (world xy, m), sightings, and what has happened to it."""

    id: int
    x: float
    y: float
    weight: float
    sightings: int = 1
    found: bool = False
    status: str = "seen"  # seen -> found -> collected | abandoned
    attempts: int = 0
    first_estimate: tuple[float, float] | None = None
    history: list[tuple[float, float]] = field(default_factory=list)

    @property
    def xy(self) -> tuple[float, float]:
        """Current centre estimate, world frame, m."""
        return (self.x, self.y)


def fit_circle(points: np.ndarray, origin: np.ndarray, radius: float, iterations: int = 8) -> np.ndarray:
    """Centre (x, y) of a circle of known ``radius`` through ``points`` (n, 2) seen from ``origin`` (2,)."""
    mean = points.mean(axis=0)
    away = mean - origin
    centre = mean + radius * away / max(float(np.linalg.norm(away)), 1e-9)
    start = centre.copy()
    for _ in range(iterations):
        d = points - centre
        dist = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        residual = dist - radius
        jac = -d / dist[:, None]
        # Gauss-Newton step: the least-squares solution of jac @ step = -residual, from the 2 x 2 normal equations
        # (np.linalg.lstsq's SVD costs ten times more for two unknowns); lstsq only for a rank-deficient jac.
        (a, b), (_, c) = jac.T @ jac
        g0, g1 = -(jac.T @ residual)
        det = a * c - b * b
        if det > 1e-12 * a * c:
            step = np.array([(c * g0 - b * g1) / det, (a * g1 - b * g0) / det])
        else:
            step, *_ = np.linalg.lstsq(jac, -residual, rcond=None)
        centre = centre + step
        if abs(step[0]) + abs(step[1]) < 1e-9:  # converged (a nanometre): further steps change nothing
            break
    if np.linalg.norm(centre - start) > radius or np.linalg.norm(centre - origin) < np.linalg.norm(mean - origin):
        return start  # too few points for the fit: keep the geometric guess
    return centre


def clusters(points: np.ndarray, gap: float) -> list[np.ndarray]:
    """Split points (n, 2) in scan order into runs whose neighbours are closer than ``gap``; wraps around."""
    if len(points) == 0:
        return []
    jumps = np.hypot(*np.diff(points, axis=0).T) > gap
    runs = np.split(points, np.nonzero(jumps)[0] + 1)
    if len(runs) > 1 and np.hypot(*(points[0] - points[-1])) <= gap:
        runs[0] = np.vstack([runs.pop(), runs[0]])
    return runs


class Discovery:
    """Tracks objects seen in successive scans; reports newly found ones once."""

    def __init__(self, cfg: DiscoveryConfig, map_boxes: Sequence[tuple[tuple[float, float], tuple[float, float]]]):
        self.cfg = cfg
        grow = cfg.map_margin
        self.boxes = np.array([[lo[0] - grow, lo[1] - grow, hi[0] + grow, hi[1] + grow] for lo, hi in map_boxes])
        self.tracks: list[Track] = []

    def unknown_points(self, scan: LaserScan) -> np.ndarray:
        """Scan hits (world xy, scan order) that are neither known map nor floor nor out of discovery range."""
        keep = scan.hits & (scan.ranges <= self.cfg.detect_range) & (scan.points[:, 2] > self.cfg.ground_height)
        pts = scan.points[keep][:, :2]
        if len(self.boxes) and len(pts):
            b = self.boxes
            inside = ((pts[:, None, 0] >= b[:, 0]) & (pts[:, None, 0] <= b[:, 2])
                      & (pts[:, None, 1] >= b[:, 1]) & (pts[:, None, 1] <= b[:, 3])).any(axis=1)
            pts = pts[~inside]
        return pts

    def sightings(self, scan: LaserScan) -> list[np.ndarray]:
        """Object centres (world xy) seen in this scan."""
        origin = np.asarray(scan.origin[:2])
        out = []
        for run in clusters(self.unknown_points(scan), self.cfg.cluster_gap):
            if len(run) < self.cfg.min_points:
                continue
            if np.hypot(*(run.max(axis=0) - run.min(axis=0))) > self.cfg.max_size:
                continue
            out.append(fit_circle(run, origin, self.cfg.object_radius))
        return out

    def update(self, scan: LaserScan) -> list[Track]:
        """Fold one scan in; return tracks found (confirmed) by this scan."""
        newly = []
        for centre in self.sightings(scan):
            track = self._associate(centre)
            if track is None:
                self.tracks.append(Track(len(self.tracks), float(centre[0]), float(centre[1]), 1.0))
                continue
            if track.status == "collected":
                continue
            w = track.weight
            track.x, track.y = (w * track.x + centre[0]) / (w + 1), (w * track.y + centre[1]) / (w + 1)
            track.weight = min(w + 1, 20.0)  # a pushed object moves: keep following it
            track.sightings += 1
            if not track.found and track.sightings >= self.cfg.confirm_scans:
                track.found, track.status = True, "found"
                track.first_estimate = track.xy
                newly.append(track)
        return newly

    def _associate(self, centre: np.ndarray) -> Track | None:
        best, best_d = None, self.cfg.associate
        for track in self.tracks:
            d = math.hypot(track.x - centre[0], track.y - centre[1])
            if d < best_d:
                best, best_d = track, d
        return best

    def nearest_pending(self, x: float, y: float, max_attempts: int) -> Track | None:
        """The closest found object that is neither collected nor given up on."""
        pending = [t for t in self.tracks if t.status == "found" and t.attempts < max_attempts]
        return min(pending, key=lambda t: math.hypot(t.x - x, t.y - y), default=None)

    def mark_collected(self, at: tuple[float, float]) -> Track | None:
        """Mark the found track nearest to where the collector took an object as collected."""
        cands = [t for t in self.tracks if t.status in ("found", "seen", "abandoned")]
        track = min(cands, key=lambda t: math.hypot(t.x - at[0], t.y - at[1]), default=None)
        if track is not None and math.hypot(track.x - at[0], track.y - at[1]) < 3 * self.cfg.associate:
            track.status = "collected"
            return track
        return None
