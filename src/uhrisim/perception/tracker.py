"""A multi-target tracker of sonar blobs in the local frame.

Each track is a constant-velocity Kalman filter on (north, east, v_north, v_east) — local
NED, m and m/s — with white-noise acceleration of spectral density ``accel_std²``
(Bar-Shalom, Li & Kirubarajan 2001, §6.3.2). A blob is a position measurement whose
covariance is set in polar form (range σ_r, cross-range r·σ_θ, each widened by the
blob's extent/√12, the standard deviation of a uniform spread over the extent) and
rotated into NED at the blob's bearing.

Per ping: every track is predicted to the ping time; blobs inside a track's χ² gate
(squared Mahalanobis distance of the innovation ≤ ``gate_chi2``) are candidates and a
global nearest-neighbour assignment (Hungarian, on the squared distances) pairs tracks
and blobs; unpaired blobs start tentative tracks. A tentative track is confirmed after
M hits in its last N pings and deleted when M can no longer be reached. A confirmed
track *coasts* (predicted, not updated) when it misses; it is deleted after
``max_coast_s`` without a hit while its predicted position is inside the fan, or after
``max_coast_outside_s`` while it is outside (a target that left the fan is not
"missed" — it cannot be seen), and when its position σ exceeds ``max_position_std_m``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from uhrisim.core.errors import ConfigError
from uhrisim.perception.blobs import Blob

TENTATIVE, CONFIRMED = "tentative", "confirmed"


@dataclass(frozen=True)
class TrackerParams:
    """Settings of the tracker (SI; module docstring).

    Attributes:
        accel_std: process noise, white-noise acceleration σ, m/s².
        range_std_m, bearing_std_deg: measurement noise of a point blob.
        extent_weight: share of a blob's extent/√12 added to its measurement σ.
        object_std_m: floor of the measurement σ: where on an extended body the echo
            centre falls wanders from ping to ping (a diver's fins, tank and head).
        edge_factor: cross-range σ multiplier of a blob that touches the fan's side edge
            (only the part inside the fan is seen, so its centre is pulled inwards).
        initial_speed_std: velocity σ of a new track, m/s.
        gate_chi2: gate on the squared Mahalanobis distance (2 dof; 9.21 = 99 %).
        confirm_m, confirm_n: M hits in the last N pings confirm a track.
        max_coast_s, max_coast_outside_s: coasting limits inside / outside the fan, s.
        max_position_std_m: a track whose position σ grows beyond this is deleted, m.
        fan_margin_m: a prediction closer than this to the fan's edges counts as outside.
        duplicate_m: two tracks closer than this are one object: the younger is deleted,
            and no track is started this close to a confirmed one (a second blob of an
            extended body does not grow a twin track).
        max_tracks: most tracks kept (new tentative ones beyond it are not started).
    """

    accel_std: float = 0.4
    range_std_m: float = 0.08
    bearing_std_deg: float = 1.0
    extent_weight: float = 0.5
    object_std_m: float = 0.25
    edge_factor: float = 3.0
    initial_speed_std: float = 1.0
    gate_chi2: float = 9.21
    confirm_m: int = 4
    confirm_n: int = 6
    max_coast_s: float = 2.0
    max_coast_outside_s: float = 5.0
    max_position_std_m: float = 3.0
    fan_margin_m: float = 0.3
    duplicate_m: float = 0.9
    max_tracks: int = 40

    def __post_init__(self) -> None:
        for name in ("edge_factor", "object_std_m", "accel_std", "range_std_m",
                     "bearing_std_deg", "initial_speed_std",
                     "gate_chi2", "max_coast_s", "max_coast_outside_s", "max_position_std_m"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ConfigError(f"must be a finite number > 0, got {v!r}",
                                  f"TrackerParams.{name}")
        if not (isinstance(self.confirm_n, int) and isinstance(self.confirm_m, int)
                and 1 <= self.confirm_m <= self.confirm_n):
            raise ConfigError(f"need 1 <= confirm_m <= confirm_n, got {self.confirm_m}, "
                              f"{self.confirm_n}", "TrackerParams.confirm_m")


@dataclass
class TrackFeatures:
    """Running means (exponential, weight ``rate`` per hit) of a track's blob features."""

    rate: float = 0.2
    cross_extent_m: float = 0.0
    range_extent_m: float = 0.0
    excess_level: float = 0.0
    level_var: float = 0.0
    contrast: float = 0.0
    parts: float = 0.0
    hits: int = 0

    def update(self, blob: Blob) -> None:
        a = 1.0 if self.hits == 0 else self.rate
        d = blob.excess_level - self.excess_level
        self.cross_extent_m += a * (blob.cross_extent_m - self.cross_extent_m)
        self.range_extent_m += a * (blob.range_extent_m - self.range_extent_m)
        self.excess_level += a * d
        self.level_var = (1.0 - a) * (self.level_var + a * d * d)
        self.contrast += a * (blob.contrast - self.contrast)
        self.parts += a * (blob.parts - self.parts)
        self.hits += 1


@dataclass
class Track:
    """One track: state (north, east, v_north, v_east) in local NED, covariance, status."""

    id: int
    x: NDArray[np.float64]
    P: NDArray[np.float64]
    t: float
    t_born: float
    t_last_hit: float
    status: str = TENTATIVE
    history: deque = field(default_factory=deque)
    hits: int = 1
    features: TrackFeatures = field(default_factory=TrackFeatures)
    last_blob: Blob | None = None
    visible: bool = True
    diver_log_odds: float = 0.0

    @property
    def position(self) -> NDArray[np.float64]:
        return self.x[:2]

    @property
    def velocity(self) -> NDArray[np.float64]:
        return self.x[2:]

    @property
    def speed(self) -> float:
        return float(math.hypot(self.x[2], self.x[3]))

    @property
    def position_std_m(self) -> float:
        """Largest position standard deviation, m."""
        a, b, c = self.P[0, 0], self.P[0, 1], self.P[1, 1]
        return math.sqrt(0.5 * (a + c) + math.hypot(0.5 * (a - c), b))

    @property
    def confirmed(self) -> bool:
        return self.status == CONFIRMED


def measurement_covariance(blob: Blob, sonar_yaw: float, params: TrackerParams
                           ) -> NDArray[np.float64]:
    """2×2 NED covariance (m²) of a blob's position (module docstring)."""
    k = params.extent_weight / math.sqrt(12.0)
    s_r = math.hypot(params.range_std_m, k * blob.range_extent_m, params.object_std_m)
    s_c = math.hypot(blob.range_m * math.radians(params.bearing_std_deg),
                     k * blob.cross_extent_m, params.object_std_m)
    if blob.touches_edge:
        s_c *= params.edge_factor
    a = sonar_yaw + blob.bearing_rad
    c, s = math.cos(a), math.sin(a)
    rot = np.array([[c, -s], [s, c]])
    return rot @ np.diag([s_r * s_r, s_c * s_c]) @ rot.T


def gate_distances(x: NDArray, P: NDArray, Z: NDArray, R: NDArray) -> NDArray[np.float64]:
    """Squared Mahalanobis distances (z − x)ᵀ(P + R)⁻¹(z − x) of a predicted position
    ``x`` (2,) with covariance ``P`` (2, 2) to measurements ``Z`` (n, 2) with covariances
    ``R`` (n, 2, 2): the 2×2 inverse written out, for all n at once."""
    y0, y1 = Z[:, 0] - x[0], Z[:, 1] - x[1]
    s00, s01, s11 = P[0, 0] + R[:, 0, 0], P[0, 1] + R[:, 0, 1], P[1, 1] + R[:, 1, 1]
    det = s00 * s11 - s01 * s01
    return (s11 * y0 * y0 - 2.0 * s01 * y0 * y1 + s00 * y1 * y1) / det


@dataclass(frozen=True)
class FanView:
    """Where the sonar looked: horizontal pose (north m, east m, yaw rad) and its fan
    (range window m, half field of view rad)."""

    north: float
    east: float
    yaw: float
    range_min_m: float
    range_max_m: float
    half_fov_rad: float

    def contains(self, north: float, east: float, margin_m: float = 0.0) -> bool:
        dn, de = north - self.north, east - self.east
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        x, y = c * dn + s * de, -s * dn + c * de
        r = math.hypot(x, y)
        if not self.range_min_m + margin_m <= r <= self.range_max_m - margin_m:
            return False
        return abs(math.atan2(y, x)) <= self.half_fov_rad - margin_m / max(r, 1e-9)


class MultiTargetTracker:
    """Tracks blobs ping by ping (module docstring). Deterministic: no randomness."""

    def __init__(self, params: TrackerParams | None = None) -> None:
        self.params = params if params is not None else TrackerParams()
        self.tracks: list[Track] = []
        self.deleted: list[Track] = []
        self._next_id = 1
        self._H = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])

    # -- Kalman steps ----------------------------------------------------------------------
    def predict(self, track: Track, t: float) -> None:
        """Predict ``track`` to time ``t`` (s); no-op for t ≤ track.t."""
        dt = t - track.t
        if dt <= 0.0:
            return
        F = np.eye(4)
        F[0, 2] = F[1, 3] = dt
        q = self.params.accel_std ** 2
        q11, q12, q22 = dt ** 3 / 3.0 * q, dt ** 2 / 2.0 * q, dt * q
        Q = np.array([[q11, 0, q12, 0], [0, q11, 0, q12], [q12, 0, q22, 0], [0, q12, 0, q22]])
        track.x = F @ track.x
        track.P = F @ track.P @ F.T + Q
        track.t = t

    def _innovation(self, track: Track, z: NDArray, R: NDArray
                    ) -> tuple[NDArray, NDArray]:
        y = z - track.x[:2]
        S = track.P[:2, :2] + R
        return y, S

    def _update(self, track: Track, z: NDArray, R: NDArray) -> None:
        y, S = self._innovation(track, z, R)
        K = track.P[:, :2] @ np.linalg.inv(S)
        track.x = track.x + K @ y
        IKH = np.eye(4) - K @ self._H
        track.P = IKH @ track.P @ IKH.T + K @ R @ K.T  # Joseph form: stays symmetric PSD
        track.P = 0.5 * (track.P + track.P.T)

    # -- one ping -------------------------------------------------------------------------
    def step(self, t: float, blobs: tuple[Blob, ...] | list[Blob], view: FanView
             ) -> dict[int, int]:
        """Take the blobs of a ping at ``t`` (s) seen from ``view``; return the pairs
        track id → blob index of this ping."""
        p = self.params
        for tr in self.tracks:
            self.predict(tr, t)
            tr.visible = view.contains(tr.x[0], tr.x[1], p.fan_margin_m)
        zs = [np.array([b.north_m, b.east_m]) for b in blobs]
        Rs = [measurement_covariance(b, view.yaw, p) for b in blobs]
        pairs: dict[int, int] = {}
        if self.tracks and blobs:
            big = 1e9
            Z, Rm = np.array(zs), np.array(Rs)
            cost = np.full((len(self.tracks), len(blobs)), big)
            for i, tr in enumerate(self.tracks):
                d2 = gate_distances(tr.x[:2], tr.P[:2, :2], Z, Rm)
                cost[i] = np.where(d2 <= p.gate_chi2, d2, big)
            rows, cols = linear_sum_assignment(cost)
            for i, j in zip(rows, cols, strict=True):
                if cost[i, j] < big:
                    pairs[self.tracks[i].id] = int(j)
        by_id = {tr.id: tr for tr in self.tracks}
        for tid, j in pairs.items():
            tr = by_id[tid]
            self._update(tr, zs[j], Rs[j])
            tr.t_last_hit = t
            tr.hits += 1
            tr.last_blob = blobs[j]
            tr.features.update(blobs[j])
        survivors = []
        for tr in self.tracks:
            hit = tr.id in pairs
            if hit or tr.visible:  # a track outside the fan is not missed, only coasts
                tr.history.append(hit)
                while len(tr.history) > p.confirm_n:
                    tr.history.popleft()
            if self._keep(tr, t):
                survivors.append(tr)
            else:
                self.deleted.append(tr)
        self.tracks = self._without_twins(survivors)
        used = set(pairs.values())
        held = [tr.x[:2] for tr in self.tracks if tr.confirmed]
        for j, b in enumerate(blobs):
            if j in used or len(self.tracks) >= p.max_tracks:
                continue
            if any(math.dist(zs[j], x) < p.duplicate_m for x in held):
                continue
            self.tracks.append(self._start(t, b, zs[j], Rs[j]))
        live = {tr.id for tr in self.tracks}
        return {i: j for i, j in pairs.items() if i in live}

    def _without_twins(self, tracks: list[Track]) -> list[Track]:
        """``tracks`` less the younger of any two closer than ``duplicate_m`` (a confirmed
        track outranks a tentative one)."""
        ranked = sorted(tracks, key=lambda tr: (not tr.confirmed, tr.t_born, tr.id))
        kept: list[Track] = []
        for tr in ranked:
            if any(math.dist(tr.x[:2], k.x[:2]) < self.params.duplicate_m for k in kept):
                self.deleted.append(tr)
            else:
                kept.append(tr)
        return sorted(kept, key=lambda tr: tr.id)

    def _keep(self, tr: Track, t: float) -> bool:
        p = self.params
        if tr.status == TENTATIVE:
            hits = sum(tr.history)
            if hits >= p.confirm_m:
                tr.status = CONFIRMED
                return True
            return hits + (p.confirm_n - len(tr.history)) >= p.confirm_m and (
                t - tr.t_last_hit <= p.max_coast_s)
        limit = p.max_coast_s if tr.visible else p.max_coast_outside_s
        return t - tr.t_last_hit <= limit and tr.position_std_m <= p.max_position_std_m

    def _start(self, t: float, blob: Blob, z: NDArray, R: NDArray) -> Track:
        P = np.zeros((4, 4))
        P[:2, :2] = R
        P[2, 2] = P[3, 3] = self.params.initial_speed_std ** 2
        tr = Track(self._next_id, np.array([z[0], z[1], 0.0, 0.0]), P, t, t, t,
                   history=deque([True]), last_blob=blob)
        tr.features.update(blob)
        self._next_id += 1
        return tr
