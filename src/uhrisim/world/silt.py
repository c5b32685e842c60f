"""Silt kicked up by a walking diver: puffs that spread, drift and settle (Stokes).

Every footfall of the weighted-boots diver on a soft floor (mud) resuspends a puff of
sediment (:meth:`SiltCloud.release`). A puff holds a few grain-size classes (silt is
2-63 µm, Wentworth 1922). Each class:

* **settles** at its Stokes speed ``w_s = (rho_s - rho_w) g d² / (18 mu)`` (Stokes 1851;
  valid while the grain Reynolds number ``w_s d / nu`` is below ~0.5: 0.2 for 63 µm
  quartz in sea water, so through the whole silt range);
* starts as a layer ``initial_height_m`` thick over the floor, uniform in height, whose
  top falls at ``w_s`` with no vertical mixing in still water (the dilute limit of
  Kynch's sedimentation theory, 1952): inside the layer the concentration stays, the
  suspended mass falls linearly, ``M(t) = M0 (1 - w_s t / H0)``, and what leaves it lies
  on the floor;
* **spreads** horizontally as a Gaussian whose variance grows by ``2 K t``
  (``sigma² = sigma0² + 2 K t``; Fickian diffusion with the horizontal eddy diffusivity
  K, default 2e-4 m²/s, Okubo's 1971 diffusion diagram at the 1 m scale), and drifts with
  the current.

So the concentration of class c of a puff released at (x0, y0) at time t0 is

    C = M0_c / (2 pi sigma² H0) exp(-r² / (2 sigma²))
        for 0 <= height above the floor <= H0 - w_s (t - t0), else 0

and spreading conserves mass exactly (tested), as does settling (suspended + deposited
= released).

The source strength is the sediment under a boot sole eroded to ``erosion_depth_m``:
``M0 = sole area x erosion depth x dry bulk density`` (defaults, **assumed**: a 0.32 m x
0.13 m sole, 1 mm eroded per step, a soft mud of dry bulk density 500 kg/m³: 21 g per
step), split over the classes by ``mass_fractions``.

What the sensors need: :meth:`SiltCloud.concentration` at points,
:meth:`SiltCloud.path_integral` along a ray (kg/m², sampled: the slow reference) and
:meth:`SiltCloud.ray_integrals` along many rays at once, in closed form (the floor taken
level under each puff: the Gaussian integrates to error functions over where the ray is
inside the layer), whole or per range bin; :class:`SiltMedium` is the cloud at one
instant as the camera and the sonar see it. :func:`beam_attenuation` turns a
concentration into extra beam attenuation for the camera's water model (mass-specific
attenuation of mineral particles, ~0.5 m²/g, range 0.2-1: Boss et al., Limnol. Oceanogr.
Methods 7:803-810, 2009), :func:`volume_backscatter_db` into the sonar's volume
backscattering strength (Rayleigh scattering by small fluid spheres: Anderson, JASA 22,
1950; Medwin & Clay, *Fundamentals of Acoustical Oceanography*, 1998, §7.5).

Sea water here: density 1025 kg/m³, dynamic viscosity 1.08e-3 Pa s (35 g/kg at 20 °C,
Sharqawy, Lienhard & Zubair, Desalination and Water Treatment 16:354-380, 2010); quartz
grains 2650 kg/m³.
"""

from __future__ import annotations

import ctypes
import importlib
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import erf

from uhrisim.core.checks import require_positive
from uhrisim.core.compiled import jit_with, numba_module
from uhrisim.core.errors import ConfigError
from uhrisim.dynamics.free_body import GRAVITY, WATER_DENSITY

SEAWATER_VISCOSITY = 1.08e-3  # Pa s
QUARTZ_DENSITY = 2650.0  # kg/m³
SOUND_SPEED = 1500.0  # m/s
#: |x| beyond which erf(x) rounds to ±1 in float64 (erfc(6.5) = 4e-20, far below half an
#: ulp of 1, 1.1e-16): a Gaussian's integral past that many scaled units adds exactly 0
_ERF_SATURATES = 6.5


def stokes_speed(diameter_m: float, grain_density: float = QUARTZ_DENSITY,
                 viscosity: float = SEAWATER_VISCOSITY, rho: float = WATER_DENSITY) -> float:
    """Stokes settling speed (m/s) of a sphere of ``diameter_m`` (module docstring)."""
    return (grain_density - rho) * GRAVITY * diameter_m ** 2 / (18.0 * viscosity)


@dataclass(frozen=True)
class SiltParams:
    """A soft floor's silt and how a footfall stirs it (SI; module docstring)."""

    diameters_m: tuple[float, ...] = (8e-6, 20e-6, 45e-6)
    mass_fractions: tuple[float, ...] = (0.3, 0.4, 0.3)
    grain_density: float = QUARTZ_DENSITY
    sole_area_m2: float = 0.32 * 0.13
    erosion_depth_m: float = 1e-3
    dry_bulk_density: float = 500.0
    initial_height_m: float = 0.3
    initial_sigma_m: float = 0.2
    diffusivity_m2s: float = 2e-4
    current_ne: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if len(self.diameters_m) != len(self.mass_fractions) or not self.diameters_m:
            raise ConfigError("needs one mass fraction per diameter", where="SiltParams")
        if abs(sum(self.mass_fractions) - 1.0) > 1e-9 or min(self.mass_fractions) < 0:
            raise ConfigError(f"must be >= 0 and add up to 1, got {self.mass_fractions}",
                              where="SiltParams.mass_fractions")
        if not all(2e-6 <= d <= 63e-6 for d in self.diameters_m):
            raise ConfigError(f"silt is 2-63 µm (Wentworth), got {self.diameters_m}",
                              where="SiltParams.diameters_m")
        require_positive(self, ("sole_area_m2", "erosion_depth_m", "dry_bulk_density",
                                "initial_height_m", "initial_sigma_m", "grain_density"),
                         "SiltParams")
        require_positive(self, ("diffusivity_m2s",), "SiltParams", allow_zero=True)

    @property
    def settling_speeds(self) -> NDArray[np.float64]:
        """(K,) Stokes speed of every class (m/s)."""
        return np.array([stokes_speed(d, self.grain_density) for d in self.diameters_m])

    @property
    def footfall_mass_kg(self) -> float:
        """Sediment one footfall resuspends (kg)."""
        return self.sole_area_m2 * self.erosion_depth_m * self.dry_bulk_density


@dataclass
class SiltCloud:
    """All puffs released so far, and what has settled (module docstring).

    ``floor_depth(north, east)`` gives the floor depth (m, down) under points (arrays);
    the layers lie on it. Mutable: the simulation releases puffs; queries read it.
    """

    params: SiltParams
    floor_depth: Callable[[ArrayLike, ArrayLike], ArrayLike]
    _t0: list[float] = field(default_factory=list)
    _origin: list[tuple[float, float]] = field(default_factory=list)
    _mass: list[NDArray[np.float64]] = field(default_factory=list)  # (K,) per puff
    _released_kg: float = 0.0
    #: the floor under the puffs' centres the last time (they move only with a current):
    #: a cache keyed by the centres' bytes, valid for the ``floor_depth`` given at
    #: construction (not a parameter)
    _floor_under: tuple[bytes, NDArray[np.float64]] = field(
        default=(b"", np.zeros(0)), init=False, repr=False, compare=False)

    def release(self, t: float, position_ned: ArrayLike, mass_kg: float | None = None) -> None:
        """A footfall at ``t`` (s) at ``position_ned`` (the floor under it is what counts):
        ``mass_kg`` (default: the params' footfall mass) split over the classes."""
        m = self.params.footfall_mass_kg if mass_kg is None else float(mass_kg)
        if not (math.isfinite(m) and m >= 0.0):
            raise ConfigError(f"must be >= 0 kg, got {mass_kg!r}", where="SiltCloud.release")
        p = np.asarray(position_ned, dtype=float)
        self._t0.append(float(t))
        self._origin.append((float(p[0]), float(p[1])))
        self._mass.append(m * np.asarray(self.params.mass_fractions))
        self._released_kg += m

    @property
    def n_puffs(self) -> int:
        return len(self._t0)

    @property
    def released_kg(self) -> float:
        return self._released_kg

    def _state(self, t: float) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        """Per puff: centre (P, 2), sigma (P,), age (P,); per puff and class: mass inside
        (P, K) and layer top height (P, K) at ``t`` (puffs not yet released: mass 0)."""
        p = self.params
        age = t - np.asarray(self._t0)
        born = age >= 0.0
        age = np.maximum(age, 0.0)
        centre = np.asarray(self._origin).reshape(-1, 2) + np.outer(age, p.current_ne)
        sigma = np.sqrt(p.initial_sigma_m ** 2 + 2.0 * p.diffusivity_m2s * age)
        top = np.maximum(p.initial_height_m - np.outer(age, p.settling_speeds), 0.0)
        mass = np.asarray(self._mass).reshape(-1, len(p.diameters_m)) * born[:, None]
        return centre, sigma, age, mass, top

    def suspended_kg(self, t: float) -> NDArray[np.float64]:
        """(K,) mass of each class still in the water at ``t`` (kg)."""
        if not self._t0:
            return np.zeros(len(self.params.diameters_m))
        _, _, _, mass, top = self._state(t)
        return np.sum(mass * top / self.params.initial_height_m, axis=0)

    def deposited_kg(self, t: float) -> NDArray[np.float64]:
        """(K,) mass of each class settled back onto the floor by ``t`` (kg)."""
        if not self._t0:
            return np.zeros(len(self.params.diameters_m))
        _, _, _, mass, _ = self._state(t)
        return mass.sum(axis=0) - self.suspended_kg(t)

    def concentration(self, points_ned: ArrayLike, t: float) -> NDArray[np.float64]:
        """Mass concentration (kg/m³) at (N, 3) NED points at ``t`` (all classes)."""
        pts = np.atleast_2d(np.asarray(points_ned, dtype=float))
        if not self._t0:
            return np.zeros(len(pts))
        centre, sigma, _, mass, top = self._state(t)
        height = np.asarray(self.floor_depth(pts[:, 0], pts[:, 1]), dtype=float) - pts[:, 2]
        height = np.where(np.isfinite(height), height, -1.0)  # off the floor: no silt
        r2 = ((pts[:, None, 0] - centre[None, :, 0]) ** 2
              + (pts[:, None, 1] - centre[None, :, 1]) ** 2)  # (N, P)
        spread = np.exp(-0.5 * r2 / sigma ** 2) / (2.0 * math.pi * sigma ** 2)  # 1/m²
        inside = ((height[:, None, None] >= 0.0)
                  & (height[:, None, None] <= top[None])).astype(float)
        per_height = mass / self.params.initial_height_m  # kg/m, (P, K)
        return np.einsum("np,npk,pk->n", spread, inside, per_height)

    def path_integral(self, origin_ned: ArrayLike, direction: ArrayLike, length: float,
                      t: float, samples: int = 256) -> float:
        """∫ C ds (kg/m²) along the ray from ``origin_ned`` along unit ``direction`` for
        ``length`` m (midpoint rule on ``samples`` points)."""
        o = np.asarray(origin_ned, dtype=float)
        d = np.asarray(direction, dtype=float)
        ds = length / samples
        s = (np.arange(samples) + 0.5) * ds
        return float(self.concentration(o + s[:, None] * d, t).sum() * ds)


    def ray_integrals(self, origin_ned: ArrayLike, directions: ArrayLike, ends: ArrayLike,
                      t: float, weights: ArrayLike, edges: ArrayLike | None = None,
                      compiled: bool = True
                      ) -> NDArray[np.float64] | tuple[NDArray, NDArray, NDArray]:
        """``∫ Σ_c w_c C_c ds`` along the rays from ``origin_ned`` along unit ``directions``
        (N, 3) up to ``ends`` (N,) m, in closed form, ``weights`` (K,) per class (per
        kg/m³). Without ``edges``: (N,) per ray. With range-bin ``edges`` (B + 1,) m:
        the nonzero integrals over each bin as (ray, bin, value) arrays.

        Each puff's layer is taken over a level floor at the floor depth under its centre;
        along a ray the horizontal Gaussian is exp(-a (s - s*)² / 2σ²) exp(-r⊥² / 2σ²)
        (a = |d_h|², s* the closest approach, r⊥ its distance), whose integral over the
        stretch [s0, s1] the ray spends in the layer is a difference of error functions.
        Puffs farther than 5σ from a ray are skipped (exp(-12.5) ~ 4e-6). With numba
        installed and ``compiled``, the rays and puffs are walked in compiled loops
        (:func:`_ray_windows`, :func:`_window_integrals`: the same numbers bit for bit; the
        numpy path is their reference, ``UHRISIM_NUMBA=0``)."""
        o = np.asarray(origin_ned, dtype=float)
        d = np.atleast_2d(np.asarray(directions, dtype=float))
        end = np.broadcast_to(np.asarray(ends, dtype=float), (len(d),))
        w = np.asarray(weights, dtype=float)
        empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
        if not self._t0:
            return np.zeros(len(d)) if edges is None else empty
        centre, sigma, _, mass, top = self._state(t)
        key = centre.tobytes()
        if key != self._floor_under[0]:
            self._floor_under = (key, np.asarray(self.floor_depth(centre[:, 0], centre[:, 1]),
                                                 dtype=float))
        live = np.flatnonzero((mass * top).sum(axis=1) > 0.0)
        centre, sigma, mass, top, floor = (centre[live], sigma[live], mass[live], top[live],
                                           self._floor_under[1][live])
        # closest approach of every ray to every puff's axis, horizontally: (N, P)
        rel = o[:2][None, :] - centre  # (P, 2)
        along = (d[:, :2] @ rel.T)  # (N, P): (o_h - c) . d_h
        kernels = _compiled_ray_integrals() if compiled else None
        if kernels is not None:
            return _compiled_integrals(kernels, o, d, end, w, along, rel, sigma, mass, top,
                                       floor, self.params.initial_height_m, edges)
        a = np.maximum(d[:, 0] ** 2 + d[:, 1] ** 2, 1e-12)[:, None]
        s_star = -along / a
        r2 = np.maximum((rel ** 2).sum(axis=1)[None, :] - along ** 2 / a, 0.0)
        ray, puff = np.nonzero(r2 < (5.0 * sigma[None, :]) ** 2)
        s_star, r2, a = s_star[ray, puff], r2[ray, puff], a[ray, 0]
        # the stretch in each class's layer: floor - top <= o_z + s d_z <= floor, s in [0, end]
        dz = d[ray, 2][:, None]
        lo_z = (floor[puff][:, None] - top[puff]) - o[2]  # (M, K)
        hi_z = np.broadcast_to((floor[puff] - o[2])[:, None], lo_z.shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            s_a, s_b = lo_z / dz, hi_z / dz
        flat = np.abs(dz) < 1e-12
        inside = (lo_z <= 0.0) & (hi_z >= 0.0)
        s0 = np.where(flat, np.where(inside, 0.0, np.inf), np.minimum(s_a, s_b))
        s1 = np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(s_a, s_b))
        scale = (np.sqrt(a) / (math.sqrt(2.0) * sigma[puff]))[:, None]
        # beyond _ERF_SATURATES / scale of the closest approach erf is ±1 in float64: the
        # stretch is cut to that (exact: what is cut adds exactly 0)
        reach = _ERF_SATURATES / scale
        s0 = np.maximum(np.maximum(s0, 0.0), s_star[:, None] - reach)
        s1 = np.minimum(np.minimum(s1, end[ray][:, None]), s_star[:, None] + reach)
        useful = np.flatnonzero(np.any(s1 > s0, axis=1))
        if len(useful) < len(ray):
            ray, puff, s_star, r2, a = (ray[useful], puff[useful], s_star[useful],
                                        r2[useful], a[useful])
            s0, s1, scale = s0[useful], s1[useful], scale[useful]
        if not len(ray):  # (an empty bincount would be of integers)
            return np.zeros(len(d)) if edges is None else empty
        # per unit length along the ray: mass / (2 pi sigma² H0) kg/m³ x Gaussian
        amplitude = (mass[puff] * w[None, :] / (2.0 * math.pi * sigma[puff, None] ** 2
                                                * self.params.initial_height_m)
                     * np.exp(-0.5 * r2 / sigma[puff] ** 2)[:, None])  # (M, K)
        span = (math.sqrt(0.5 * math.pi) * sigma[puff] / np.sqrt(a))[:, None] * amplitude
        rel_star = s_star[:, None]

        def integral(lo: NDArray, hi: NDArray) -> NDArray:
            hi = np.maximum(hi, lo)
            return span * (erf((hi - rel_star) * scale) - erf((lo - rel_star) * scale))

        if edges is None:
            value = integral(s0, s1).sum(axis=1)
            return np.bincount(ray, weights=value, minlength=len(d))
        e = np.asarray(edges, dtype=float)
        first, last = s0.min(axis=1), s1.max(axis=1)
        keep = np.flatnonzero(last > first)
        b0 = np.clip(np.searchsorted(e, first[keep], side="right") - 1, 0, len(e) - 2)
        b1 = np.clip(np.searchsorted(e, last[keep], side="left"), 1, len(e) - 1)
        counts = np.maximum(b1 - b0, 0)
        pair = np.repeat(keep, counts)
        bins = np.repeat(b0, counts) + (np.arange(counts.sum())
                                        - np.repeat(np.cumsum(counts) - counts, counts))
        lo = np.maximum(s0[pair], e[bins][:, None])
        hi = np.minimum(s1[pair], e[bins + 1][:, None])
        value = (span[pair] * (erf((np.maximum(hi, lo) - rel_star[pair]) * scale[pair])
                               - erf((lo - rel_star[pair]) * scale[pair]))).sum(axis=1)
        cell = ray[pair] * (len(e) - 1) + bins
        cells, index = np.unique(cell, return_inverse=True)
        total = np.bincount(index, weights=value)
        nonzero = total > 0.0
        return (cells[nonzero] // (len(e) - 1), cells[nonzero] % (len(e) - 1),
                total[nonzero])


def _compiled_integrals(kernels: tuple[Any, Any], o: NDArray, d: NDArray, end: NDArray,
                        w: NDArray, along: NDArray, rel: NDArray, sigma: NDArray,
                        mass: NDArray, top: NDArray, floor: NDArray,
                        layer_m: float, edges: ArrayLike | None
                        ) -> NDArray[np.float64] | tuple[NDArray, NDArray, NDArray]:
    """:meth:`SiltCloud.ray_integrals` from ``along`` on (live puffs only) with the
    compiled ``kernels``: the pairs' stretches in the layers, their Gaussians' peaks in
    numpy (its ``exp`` may differ from libm's in the last bit), the error functions."""
    windows, integrals = kernels
    n_pairs, ray, puff, s_star, r2, scale, width, s0, s1 = windows(
        o, np.ascontiguousarray(d), np.ascontiguousarray(end), np.ascontiguousarray(along),
        (rel ** 2).sum(axis=1), (5.0 * sigma) ** 2, sigma, np.ascontiguousarray(top),
        top.max(axis=1), floor, _ERF_SATURATES)
    puff = puff[:n_pairs]
    peak = np.exp(-0.5 * r2[:n_pairs] / sigma[puff] ** 2)
    binned = edges is not None
    result = integrals(len(d), ray[:n_pairs], puff, s_star, scale, width, s0, s1, peak,
                       np.ascontiguousarray(mass), w, sigma, layer_m,
                       np.asarray(edges, dtype=float) if binned else np.zeros(0), binned)
    return result[1:] if binned else result[0]


def _np_min(x: float, y: float) -> float:
    """``np.minimum`` of two floats: NaN wins, the second of two equal values."""
    return x if x < y or x != x else y


def _np_max(x: float, y: float) -> float:
    """``np.maximum`` of two floats: NaN wins, the second of two equal values."""
    return x if x > y or x != x else y


def _erf_of(x: float) -> float:
    """scipy's ``erf`` of a float (compiled kernels call the same C function)."""
    return float(erf(x))


def _ray_windows(o, d, end, along, rel_sq, cutoff_sq, sigma, top, thickest, floor,  # type: ignore[no-untyped-def]
                 saturates):
    """The rays' and puffs' pairs :meth:`SiltCloud.ray_integrals` integrates over (compiled
    by numba), in numpy's order (by ray, then puff): their count, ray, puff, closest
    approach s*, r⊥², erf scale, sqrt(pi/2) σ / |d_h| and each class's stretch [s0, s1]
    in its layer; the numpy path's operations in its order."""
    n, p_count, k_count = d.shape[0], sigma.shape[0], top.shape[1]
    size = n * p_count
    ray, puff = np.empty(size, np.int64), np.empty(size, np.int64)
    s_star, r2_of, scale_of, width_of = (np.empty(size), np.empty(size), np.empty(size),
                                         np.empty(size))
    s0_of, s1_of = np.empty((size, k_count)), np.empty((size, k_count))
    m = 0
    for i in range(n):
        a = _np_max(d[i, 0] * d[i, 0] + d[i, 1] * d[i, 1], 1e-12)
        dz = d[i, 2]
        flat = abs(dz) < 1e-12
        for p in range(p_count):
            r2 = _np_max(rel_sq[p] - along[i, p] * along[i, p] / a, 0.0)
            if not r2 < cutoff_sq[p]:
                continue
            closest = -along[i, p] / a
            scale = math.sqrt(a) / (math.sqrt(2.0) * sigma[p])
            reach = saturates / scale
            # every class's stretch lies within [0, end], s* ± reach and (rounding being
            # monotonic) the stretch in the thickest layer: none if that is empty
            first, last = max(0.0, closest - reach), min(end[i], closest + reach)
            hi_z = floor[p] - o[2]
            s_b = hi_z / dz
            if not flat:
                s_thickest = ((floor[p] - thickest[p]) - o[2]) / dz
                first = max(first, min(s_thickest, s_b))
                last = min(last, max(s_thickest, s_b))
            if not last > first:
                continue
            useful = False
            for k in range(k_count):
                lo_z = (floor[p] - top[p, k]) - o[2]
                if flat:
                    inside = lo_z <= 0.0 and hi_z >= 0.0
                    s0 = 0.0 if inside else math.inf
                    s1 = math.inf if inside else -math.inf
                else:
                    s_a = lo_z / dz
                    s0, s1 = _np_min(s_a, s_b), _np_max(s_a, s_b)
                s0_of[m, k] = _np_max(_np_max(s0, 0.0), closest - reach)
                s1_of[m, k] = _np_min(_np_min(s1, end[i]), closest + reach)
                useful = useful or s1_of[m, k] > s0_of[m, k]
            if useful:
                ray[m], puff[m], s_star[m], r2_of[m], scale_of[m] = i, p, closest, r2, scale
                width_of[m] = math.sqrt(0.5 * math.pi) * sigma[p] / math.sqrt(a)
                m += 1
    return m, ray, puff, s_star, r2_of, scale_of, width_of, s0_of, s1_of


def _window_integrals(n_rays, ray, puff, s_star, scale, width, s0, s1, peak, mass, w,  # type: ignore[no-untyped-def]
                      sigma, layer_m, edges, binned):
    """The integrals over the first ``len(ray)`` pairs of :func:`_ray_windows` (compiled by
    numba), per ray or (``binned``) per nonzero range bin of ``edges``: (per ray, cells'
    rays, bins, values), summed in the numpy path's order (pair by pair, class by class)."""
    k_count = mass.shape[1]
    bins = max(edges.shape[0] - 1, 1)
    per_ray = np.zeros(n_rays)
    size = n_rays * bins if binned else 0
    cell_ray, cell_bin, cell_value = (np.empty(size, np.int64), np.empty(size, np.int64),
                                      np.empty(size))
    total = np.zeros(bins)
    span = np.empty(k_count)
    cells = 0
    j = 0
    while j < ray.shape[0]:
        i = ray[j]
        first_bin, last_bin = bins, 0
        while j < ray.shape[0] and ray[j] == i:  # the ray's pairs, puff by puff
            p = puff[j]
            for k in range(k_count):
                span[k] = width[j] * (mass[p, k] * w[k] / (2.0 * math.pi * (sigma[p] * sigma[p])
                                                            * layer_m) * peak[j])
            if not binned:
                value = 0.0
                for k in range(k_count):
                    hi = _np_max(s1[j, k], s0[j, k])
                    value += span[k] * (_erf_of((hi - s_star[j]) * scale[j])
                                        - _erf_of((s0[j, k] - s_star[j]) * scale[j]))
                per_ray[i] += value
                j += 1
                continue
            first, last = s0[j, 0], s1[j, 0]
            for k in range(1, k_count):
                first, last = _np_min(first, s0[j, k]), _np_max(last, s1[j, k])
            if last > first:
                b0 = min(max(np.searchsorted(edges, first, side="right") - 1, 0), bins - 1)
                b1 = min(max(np.searchsorted(edges, last, side="left"), 1), bins)
                for b in range(b0, b1):
                    value = 0.0
                    for k in range(k_count):
                        lo = _np_max(s0[j, k], edges[b])
                        hi = _np_min(s1[j, k], edges[b + 1])
                        value += span[k] * (_erf_of((_np_max(hi, lo) - s_star[j]) * scale[j])
                                            - _erf_of((lo - s_star[j]) * scale[j]))
                    total[b] += value
                first_bin, last_bin = min(first_bin, b0), max(last_bin, b1)
            j += 1
        for b in range(first_bin, last_bin):  # the ray's cells, bin by bin
            if total[b] > 0.0:
                cell_ray[cells], cell_bin[cells], cell_value[cells] = i, b, total[b]
                cells += 1
            total[b] = 0.0
    return per_ray, cell_ray[:cells], cell_bin[:cells], cell_value[:cells]


#: the symbol by which compiled kernels call scipy's ``erf`` (``scipy.special.erf`` runs
#: the same C function)
_ERF_SYMBOL = "uhrisim_scipy_special_erf"
#: scipy's C ``erf`` among ``scipy.special.cython_special``'s fused variants (bound only
#: where its capsule's signature says it takes and returns a double)
_ERF_FUSED = "__pyx_fuse_1erf"


@cache
def _compiled_ray_integrals() -> tuple[Any, Any] | None:
    """:func:`_ray_windows` and :func:`_window_integrals` compiled; None without numba (or
    where scipy does not export its C ``erf`` for doubles)."""
    numba = numba_module()
    if numba is None:
        return None
    capsule = getattr(importlib.import_module("scipy.special.cython_special"), "__pyx_capi__",
                      {}).get(_ERF_FUSED)
    if capsule is None or not _capsule_name(capsule).startswith("double (double"):
        return None  # no erf for doubles under that fused index in this scipy
    extending = importlib.import_module("numba.extending")
    binding = importlib.import_module("llvmlite.binding")  # numba's own dependency
    address = extending.get_cython_function_address("scipy.special.cython_special",
                                                    _ERF_FUSED)
    binding.add_symbol(_ERF_SYMBOL, address)
    scipy_erf = numba.types.ExternalFunction(_ERF_SYMBOL,
                                             numba.types.float64(numba.types.float64))

    @extending.overload(_erf_of)
    def _erf_compiled(x):  # type: ignore[no-untyped-def]
        return lambda x: scipy_erf(x)

    helpers = (_np_min, _np_max)
    return (jit_with(_ray_windows, helpers, numpy_errors=True),
            jit_with(_window_integrals, helpers, numpy_errors=True))


def _capsule_name(capsule: Any) -> str:
    """A Cython C-API capsule's name: its C signature, e.g. ``"double (double, int
    __pyx_skip_dispatch)"``."""
    get_name = ctypes.PYFUNCTYPE(ctypes.c_char_p, ctypes.py_object)(
        ("PyCapsule_GetName", ctypes.pythonapi))
    return get_name(capsule).decode()


@dataclass(frozen=True)
class SiltMedium:
    """The silt cloud at one instant ``t`` (s) as the sensors see it: extra beam
    attenuation along camera rays and volume backscatter along sonar beams."""

    cloud: SiltCloud
    t: float
    mass_specific_m2_g: float = 0.5

    def optical_depth(self, origin_ned: ArrayLike, directions: ArrayLike,
                      ends: ArrayLike) -> NDArray[np.float64]:
        """(N,) optical depth ∫ c_silt ds of the silt along each ray up to ``ends`` (m;
        inf: the whole way), c_silt from :func:`beam_attenuation`."""
        k = self.mass_specific_m2_g * 1e3
        weights = np.full(len(self.cloud.params.diameters_m), k)
        ends = np.minimum(np.asarray(ends, dtype=float), 1e4)
        return self.cloud.ray_integrals(origin_ned, directions, ends, self.t, weights)

    def backscatter(self, origin_ned: ArrayLike, directions: ArrayLike, ends: ArrayLike,
                    edges: ArrayLike, frequency_hz: float
                    ) -> tuple[NDArray, NDArray, NDArray]:
        """Volume backscatter of the silt in range bins along sonar rays: (ray, bin,
        ∫ s_v ds over the bin (1/m x m = 1)) for the cells with silt, s_v = 10^(S_v/10)
        of every class from :func:`volume_backscatter_db` (linear in concentration)."""
        per_kg = np.array([10.0 ** (volume_backscatter_db(1.0, frequency_hz, dia,
                                                          self.cloud.params.grain_density)
                                    / 10.0) for dia in self.cloud.params.diameters_m])
        return self.cloud.ray_integrals(origin_ned, directions, ends, self.t, per_kg,
                                        edges=edges)


def beam_attenuation(concentration_kg_m3: ArrayLike, mass_specific_m2_g: float = 0.5
                     ) -> NDArray[np.float64] | float:
    """Extra beam attenuation (1/m) of silt at ``concentration_kg_m3`` (module docstring:
    ``c = k C`` with k in m²/g; 1 kg/m³ = 1000 g/m³)."""
    return mass_specific_m2_g * 1e3 * np.asarray(concentration_kg_m3, dtype=float)


def volume_backscatter_db(concentration_kg_m3: ArrayLike, frequency_hz: float,
                          diameter_m: float = 20e-6, grain_density: float = QUARTZ_DENSITY,
                          grain_sound_speed: float = 5500.0) -> NDArray[np.float64]:
    """Volume backscattering strength S_v (dB re 1/m) of silt grains of ``diameter_m`` at
    ``concentration_kg_m3``: ``S_v = 10 log10(n sigma_bs)``, n grains per m³, sigma_bs of a
    small fluid sphere (Rayleigh, ka << 1)::

        sigma_bs = k⁴ a⁶ [ (1 - g h²) / (3 g h²) + (1 - g) / (1 + 2 g) ]²

    with g and h the grain/water density and sound-speed ratios (quartz treated as a fluid
    sphere: a stated simplification). -inf where the concentration is 0."""
    a = 0.5 * diameter_m
    k = 2.0 * math.pi * frequency_hz / SOUND_SPEED
    if k * a > 0.5:
        raise ConfigError(f"ka = {k * a:.2f}: outside the Rayleigh regime (ka << 1)",
                          where="volume_backscatter_db")
    g = grain_density / WATER_DENSITY
    h = grain_sound_speed / SOUND_SPEED
    form = (1.0 - g * h * h) / (3.0 * g * h * h) + (1.0 - g) / (1.0 + 2.0 * g)
    sigma_bs = k ** 4 * a ** 6 * form ** 2
    grain_mass = grain_density * math.pi / 6.0 * diameter_m ** 3
    n = np.asarray(concentration_kg_m3, dtype=float) / grain_mass
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(n * sigma_bs)
