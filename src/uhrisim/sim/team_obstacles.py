"""Tools, sites and loads as obstacles to the agents' collision spheres: a bounding-sphere
pre-check per body, so that the loop's ray-cast narrow phase runs only for the few bodies
an agent's move can reach (docs/teamwork.md, "Collisions with tools, sites and loads").

Each team body (a tool, a load, a site with its parts posed by its state) has a
bounding sphere in NED, made from its parts' own spheres (centre of a part's box in its
rest frame, radius to its farthest vertex), and a box in its own frame (its parts'
boxes), both moved by the body's pose and the parts' transforms; hidden parts (parked
beyond :data:`~uhrisim.world.bodies.HIDDEN_BEYOND_M`, which the ray casters skip) are
left out. :meth:`ObstacleSpheres.place` sets them when the body moves or its geometry
changes; :meth:`ObstacleSpheres.in_reach` names the bodies a sphere of ``radius`` moving
start→end can touch: those whose sphere comes within ``radius`` of the segment and
whose box grown by ``radius`` the segment meets — every point of the narrow phase's ray
bundle lies within ``radius`` of the segment
(:meth:`~uhrisim.world.scene.Scene.segment_clear`), so a body that is not named cannot
be hit. Each agent keeps a clearance to the nearest sphere (measured from an anchor
point, and lowered when a sphere is placed nearer), so a move that stays inside it costs
two distances; it is measured again when the agent leaves it or the bodies it leaves
out change.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uhrisim.world.bodies import HIDDEN_BEYOND_M, ArticulatedMesh


@dataclass(frozen=True)
class PartSpheres:
    """Bounding spheres of a body's parts in their rest frames: centres (k, 3) and radii
    (k,) (m)."""

    centres: NDArray[np.float64]
    radii: NDArray[np.float64]
    corners: NDArray[np.float64]  # (k, 8, 3) each part's box in its rest frame

    @classmethod
    def of(cls, geometry: ArticulatedMesh) -> PartSpheres:
        centres, radii, corners = [], [], []
        for part in geometry.parts:
            v = part.mesh.vertices.view(np.ndarray)
            lo, hi = v.min(axis=0), v.max(axis=0)
            centre = 0.5 * (lo + hi)
            centres.append(centre)
            radii.append(float(np.max(np.linalg.norm(v - centre, axis=1))))
            corners.append([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]]
                            for i in (0, 1) for j in (0, 1) for k in (0, 1)])
        return cls(np.array(centres), np.array(radii), np.array(corners))

    def box(self, transforms: NDArray[np.float64] | None
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The body's box in its own frame (lower and upper corners, m): its shown parts'
        boxes moved by ``transforms`` (None: at rest)."""
        if transforms is None:
            points = self.corners.reshape(-1, 3)
        else:
            shown = np.einsum("ki,ki->k", transforms[:, :3, 3],
                              transforms[:, :3, 3]) < HIDDEN_BEYOND_M ** 2
            t = transforms[shown]
            points = (np.einsum("kij,kcj->kci", t[:, :3, :3], self.corners[shown])
                      + t[:, None, :3, 3]).reshape(-1, 3)
        return points.min(axis=0), points.max(axis=0)

    def posed(self, pose: NDArray[np.float64], transforms: NDArray[np.float64] | None
              ) -> tuple[NDArray[np.float64], float]:
        """The body's bounding sphere (centre NED, radius m) at ``pose`` (4x4 body→NED)
        with its parts moved by ``transforms`` ((k, 4, 4) rest→posed; None: at rest);
        (NaN centre, 0) when every part is hidden."""
        if transforms is None:
            local, radii = self.centres, self.radii
        else:
            shown = np.einsum("ki,ki->k", transforms[:, :3, 3],
                              transforms[:, :3, 3]) < HIDDEN_BEYOND_M ** 2
            if not shown.any():
                return np.full(3, np.nan), 0.0
            t = transforms[shown]
            local = np.einsum("kij,kj->ki", t[:, :3, :3], self.centres[shown]) + t[:, :3, 3]
            radii = self.radii[shown]
        centres = local @ pose[:3, :3].T + pose[:3, 3]
        if len(radii) == 1:
            return centres[0], float(radii[0])
        centre = 0.5 * (np.min(centres - radii[:, None], axis=0)
                        + np.max(centres + radii[:, None], axis=0))
        return centre, float(np.max(np.linalg.norm(centres - centre, axis=1) + radii))


#: kept off a clearance when it rules a contact out (m): rounding of the distances
CLEARANCE_SLACK_M = 1e-9


class ObstacleSpheres:
    """The bounding spheres of named bodies (module docstring)."""

    def __init__(self, parts: dict[str, PartSpheres]) -> None:
        self.names = tuple(parts)
        self._index = {name: i for i, name in enumerate(self.names)}
        self._parts = parts
        self.centres = np.full((len(parts), 3), np.nan)
        self.radii = np.zeros(len(parts))
        #: each body's box: (rotation NED→body, origin NED, lower and upper corners)
        self._boxes: list[tuple[NDArray[np.float64], ...]] = [()] * len(parts)
        #: each body's pose and part transforms at its last placing (for its box)
        self._placed: list[tuple[NDArray[np.float64], NDArray[np.float64] | None]] = [
            (np.eye(4), None)] * len(parts)
        #: agent -> (left out, anchor NED, clearance m): a lower bound of the gap from the
        #: anchor to every sphere not left out, lowered as spheres are placed
        self._clearance: dict[str, tuple[frozenset[str], list[float], float]] = {}

    def place(self, name: str, pose: NDArray[np.float64],
              transforms: NDArray[np.float64] | None = None) -> bool:
        """Set ``name``'s sphere for its pose (4x4 body→NED) and part transforms; whether
        it changed."""
        i = self._index[name]
        centre, radius = self._parts[name].posed(pose, transforms)
        if radius == self.radii[i] and (centre == self.centres[i]).all():
            return False
        self.centres[i], self.radii[i] = centre, radius
        if radius > 0.0:
            self._boxes[i] = ()  # worked out when a move first comes near (:meth:`_box`)
            self._placed[i] = (pose.copy(), None if transforms is None else transforms.copy())
            where = centre.tolist()
            for agent, (left_out, anchor, clearance) in self._clearance.items():
                gap = math.dist(where, anchor) - radius  # a bound still: its old place is gone
                if gap < clearance and name not in left_out:
                    self._clearance[agent] = (left_out, anchor, gap)
        return True

    def sphere(self, name: str) -> tuple[NDArray[np.float64], float]:
        """``name``'s sphere: centre NED (m) (NaN: nothing shown) and radius (m)."""
        i = self._index[name]
        return self.centres[i], float(self.radii[i])

    def _kept(self, left_out: frozenset[str]) -> NDArray[np.bool_]:
        kept = self.radii > 0.0
        for name in left_out:
            if name in self._index:
                kept[self._index[name]] = False
        return kept

    def touching(self, start: Iterable[float], end: Iterable[float], radius: float,
                 left_out: frozenset[str] = frozenset()) -> list[str]:
        """The bodies (not ``left_out``) whose sphere comes within ``radius`` (m) of the
        segment start→end (NED, m): all a sphere moving along it can touch."""
        s, e = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
        d = e - s
        length2 = float(d @ d)
        c = self.centres
        u = np.zeros(len(c)) if length2 == 0.0 else np.clip((c - s) @ d / length2, 0.0, 1.0)
        gap = np.linalg.norm(c - (s + u[:, None] * d), axis=1) - self.radii
        hit = self._kept(left_out) & (gap <= radius)
        return [self.names[i] for i in np.flatnonzero(hit)
                if _meets_box(s, e, radius, *self._box(i))]

    def _box(self, i: int) -> tuple[NDArray[np.float64], ...]:
        """Body ``i``'s box: (rotation NED→body, origin NED, lower and upper corners in
        its frame, m), worked out once per placing."""
        if not self._boxes[i]:
            pose, transforms = self._placed[i]
            lo, hi = self._parts[self.names[i]].box(transforms)
            self._boxes[i] = (pose[:3, :3].T, pose[:3, 3].copy(), lo, hi)
        return self._boxes[i]

    def box_near(self, name: str, point: list[float], radius: float) -> bool:
        """Whether ``point`` (NED, m) lies in ``name``'s box grown by ``radius`` (m): else
        a sphere of ``radius`` there cannot touch the body (a cheap narrow phase first)."""
        p = np.asarray(point, dtype=float)
        return _meets_box(p, p, radius, *self._box(self._index[name]))

    def in_reach(self, agent: str, start: list[float], end: list[float], radius: float,
                 left_out: frozenset[str]) -> list[str]:
        """:meth:`touching`, with ``agent``'s clearance kept between calls (module
        docstring): empty at the cost of one distance while the move stays inside it."""
        cached = self._clearance.get(agent)
        if cached is not None and cached[0] is left_out:  # (replaced when it changes)
            reach = math.dist(cached[1], end) + math.dist(start, end) + radius
            if reach < cached[2]:
                return []
        near = self.touching(start, end, radius, left_out)
        self._measure(agent, end, left_out)
        return near

    def _measure(self, agent: str, anchor: list[float], left_out: frozenset[str]) -> float:
        """Measure ``agent``'s clearance afresh from ``anchor`` (NED, m): the gap (m) to
        the nearest sphere not ``left_out`` (inf: none), kept for the next calls."""
        kept = self._kept(left_out)
        clearance = float(np.min(np.linalg.norm(self.centres[kept] - np.asarray(anchor), axis=1)
                                 - self.radii[kept])) if kept.any() else math.inf
        self._clearance[agent] = (left_out, list(anchor), clearance)
        return clearance


def _meets_box(start: NDArray[np.float64], end: NDArray[np.float64], radius: float,
               rotation: NDArray[np.float64], origin: NDArray[np.float64],
               lo: NDArray[np.float64], hi: NDArray[np.float64]) -> bool:
    """Whether the segment start→end (NED, m) meets the body's box grown by ``radius`` on
    every side (it holds every point within ``radius`` of the box): the slab test in the
    body's frame (``rotation`` NED→body, ``origin`` NED)."""
    a = rotation @ (start - origin)
    d = rotation @ (end - start)
    enter, leave = 0.0, 1.0
    for k in range(3):
        low, high = lo[k] - radius, hi[k] + radius
        if abs(d[k]) < 1e-12:
            if not low <= a[k] <= high:
                return False
            continue
        t0, t1 = (low - a[k]) / d[k], (high - a[k]) / d[k]
        if t0 > t1:
            t0, t1 = t1, t0
        enter, leave = max(enter, t0), min(leave, t1)
        if enter > leave:
            return False
    return True
