"""The camera's per-ray image formation and its sensor, fused and compiled (numba).

:mod:`.formation` writes each stage as numpy calls over all rays; the camera then makes
some twenty passes over its ~30 000 rays a frame, and the temporaries cost more than the
arithmetic. Here the same float32 formulas run once per ray in one compiled loop
(:func:`light_of_rays`: daylight and lamplight on the surface, the direct beam, the
forward-scatter source, the daylight veil and the lamps' backscatter), and the sensor
once per pixel (:func:`expose`).

Tolerance. :func:`expose` performs numpy's float32 operations in numpy's order: its
bytes are the same. :func:`light_of_rays` does too, but its exponentials are libm's
(numpy has its own SIMD ones, which round differently in the last place) but for the
daylight veil's e^x − 1, a polynomial in SIMD lanes (:func:`_expm1`, float32's correct
rounding; libm's float32 expm1 took ~15 ns a value, a fifth of the formation loop), the sand
ripples' sines are fdlibm's polynomials in SIMD lanes (:func:`_sine`, within an ulp of
libm's: libm's cost ~24 ns each, seven per ripple sample), and it sums the three terms
of a dot product in order: each radiance differs from numpy's by a few float32 units in
the last place (measured on the salvage mission: relative 5e-7 at most; held within
1e-5). After exposure a pixel could fall on the other side of an 8-bit rounding
boundary: frames agree with the numpy path within one grey level per channel, with a
mean absolute difference below 0.01 grey level (``tests/unit/test_camera_fused.py``
holds both). Depth, range and labels come from the casts and are the same to the bit.
The noise draws are the same pool read at the same offset: same seed, same frame.

Without numba, or with ``UHRISIM_NUMBA=0``, :mod:`.camera` runs the numpy stages (the
reference).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.core.compiled import jit, jit_with
from uhrisim.sensors.camera import formation as fm
from uhrisim.sensors.camera.config import CameraConfig
from uhrisim.sensors.camera.textures import SceneTextures
from uhrisim.sensors.camera.water import WaterOptics
from uhrisim.world.materials import ripple_factor

_F32 = np.float32

# sin on [-π/4, π/4] and cos there, fdlibm's kernel polynomials (k_sin.c, k_cos.c), and
# π/2 in three parts (e_rem_pio2.c): x − n·π/2 is exact to the double for n < 2^20
_SIN = (-1.66666666666666324348e-01, 8.33333333332248946124e-03,
        -1.98412698298579493134e-04, 2.75573137070700676789e-06,
        -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_COS = (4.16666666666666019037e-02, -1.38888888888741095749e-03,
        2.48015872894767294178e-05, -2.75573143513906633035e-07,
        2.08757232129817482790e-09, -1.13596475577881948265e-11)
_PIO2 = (1.57079632673412561417e+00, 6.07710050630396597660e-11,
         2.02226624879595063154e-21)
_ROUND = 6755399441055744.0  # 1.5·2^52: x + it − it rounds x to an integer
#: the largest argument :func:`_sine` takes (n = x·2/π stays below 2^20)
SINE_LIMIT = 1.0e6
# exp(r) = Σ r^j/j! up to j = 13 for |r| ≤ ln2/2 (the next term < 3e-19 relative), after
# x = k·ln2 + r with ln2 in two parts (fdlibm's e_exp.c): 2^k from a table; exact enough
# that float32(exp(x)) is float32's correct rounding but where x lies within ~1e-15 of a
# rounding boundary
_LOG2E = 1.44269504088896338700e+00
_LN2 = (6.93147180369123816490e-01, 1.90821492927058770002e-10)
_INVERSE_FACTORIALS = tuple(1.0 / math.factorial(j) for j in range(14))
#: float32 exp and expm1 arguments are clipped to [-EXP_LOW, EXP_HIGH] (e^-150 rounds to
#: float32 0, e^120 to inf)
EXP_LOW, EXP_HIGH = 150.0, 120.0
_POWERS_OF_TWO = np.array([2.0 ** k for k in range(-217, 174)])  # 2^k, k = ⌊x/ln2⌉


@dataclass(frozen=True)
class OpticsConstants:
    """What the kernel reads of a configuration, as float32 arrays.

    ``water``: (4, 3) rows c, K_d, a + b_b (forward-scatter loss) and the daylight veil's
    per-channel scale (set per frame: it depends on the camera depth); ``lamps``: (L, 5)
    position (camera frame, m), intensity, beam concentration κ; ``table``: the lamps'
    backscatter table ((cells·K, 3), empty without lamps)."""

    water: NDArray[np.float32]
    lamps: NDArray[np.float32]
    table: NDArray[np.float32]
    range_max: float
    n_nodes: int
    sun_half: np.float32
    forward_scatter: bool

    @staticmethod
    def of(config: CameraConfig, table: NDArray[np.float32] | None,
           range_nodes: NDArray[np.float64]) -> OpticsConstants:
        from uhrisim.sensors.camera.geometry import lamp_beam_kappa

        w = config.water
        water = np.stack([w.c, w.k_d, w.a + w.b_b, np.zeros(3)]).astype(_F32)
        lamps = np.array([[*lamp.position_cam, lamp.intensity, lamp_beam_kappa(lamp)]
                          for lamp in config.lamps], _F32).reshape(-1, 5)
        return OpticsConstants(
            water, lamps, np.zeros((0, 3), _F32) if table is None else table,
            float(range_nodes[-1]), len(range_nodes), _F32(0.5 * config.sun_radiance),
            bool(config.forward_scatter and config.forward_scatter_spread > 0.0))


def _sine(x, quarters):  # type: ignore[no-untyped-def]
    """sin(x + quarters·π/2) for |x| < :data:`SINE_LIMIT` (cos: ``quarters`` = 1), within
    an ulp of libm's, written without calls or branches so that a loop of it runs in
    SIMD lanes (libm's sin takes ~24 ns here; this, vectorised, ~2)."""
    n = (x * 0.6366197723675814 + _ROUND) - _ROUND
    r = ((x - n * _PIO2[0]) - n * _PIO2[1]) - n * _PIO2[2]
    z = r * r
    s = r + r * z * (_SIN[0] + z * (_SIN[1] + z * (_SIN[2] + z * (_SIN[3] + z * (
        _SIN[4] + z * _SIN[5])))))
    c = 1.0 - 0.5 * z + z * z * (_COS[0] + z * (_COS[1] + z * (_COS[2] + z * (_COS[3] + z * (
        _COS[4] + z * _COS[5])))))
    q = (np.int64(n) + quarters) & 3
    v = c if q & 1 else s
    return -v if q & 2 else v


def _exp(x):  # type: ignore[no-untyped-def]
    """e^x in float64 for a float32 result (see :data:`_LOG2E`), written without calls or
    branches so that a loop of it runs in SIMD lanes."""
    x = min(max(x, -EXP_LOW), EXP_HIGH)
    k = (x * _LOG2E + _ROUND) - _ROUND
    r = (x - k * _LN2[0]) - k * _LN2[1]
    c = _INVERSE_FACTORIALS
    p = c[10] + r * (c[11] + r * (c[12] + r * c[13]))
    p = c[6] + r * (c[7] + r * (c[8] + r * (c[9] + r * p)))
    p = 1.0 + r * (1.0 + r * (c[2] + r * (c[3] + r * (c[4] + r * (c[5] + r * p)))))
    return p * _POWERS_OF_TWO[np.int64(k) + 217]


def _expm1(x):  # type: ignore[no-untyped-def]
    """e^x − 1 in float64 for a float32 result: :func:`_exp` − 1 (exact subtraction near
    0, an absolute error ~1e-16), for |x| < 1e-4 its Taylor series to x^5 (relative error
    < 1e-22). libm's float32 expm1 takes ~15 ns here; this ~4."""
    big = _exp(x) - 1.0  # first: a branch of its own would keep the loop out of SIMD lanes
    small = x + x * x * (0.5 + x * (1.0 / 6.0 + x * (1.0 / 24.0 + x * (1.0 / 120.0))))
    return small if abs(x) < 1e-4 else big


def _ripple_rows(north, east, constants, factor):  # type: ignore[no-untyped-def]
    """:func:`~uhrisim.world.materials.ripple_factor` at the points (``north``,
    ``east``), written into ``factor``, with :func:`_sine` (SIMD lanes)."""
    cos_a, sin_a, k, meander, contrast, grain = (constants[0], constants[1], constants[2],
                                                 constants[3], constants[4], constants[5])
    for i in range(north.shape[0]):
        n, e = north[i], east[i]
        across = n * cos_a + e * sin_a
        along = -n * sin_a + e * cos_a
        s = across + meander * _sine(k * along / 4.0, 0)
        profile = (_sine(k * s, 0) + 0.35 * _sine(2.0 * k * s, 0)) / 1.2
        mottle = _sine(37.0 * n + 11.0 * _sine(23.0 * e, 0), 0) * _sine(
            41.0 * e + 7.0 * _sine(29.0 * n, 0), 1)
        factor[i] = 1.0 + contrast * profile + grain * mottle


def _ripple_factors(distance, material, texture_kind, ripples, dirs_cam, origin,  # type: ignore[no-untyped-def]
                    rotation, factor):
    """Each ray's sand-ripple albedo factor (float32 ``factor``; 1 where the hit has no
    ripples): the hit points of each rippled material gathered, then
    :func:`_ripple_rows` over them (``ripple_factor`` itself, with libm's sines, where an
    argument could pass :data:`SINE_LIMIT`)."""
    n_rays = distance.shape[0]
    rows = np.empty(n_rays, np.int64)
    north, east, values = np.empty(n_rays), np.empty(n_rays), np.empty(n_rays)
    for i in range(n_rays):
        factor[i] = np.float32(1.0)
    for m in range(texture_kind.shape[0]):
        if texture_kind[m] != 1:
            continue
        count, reach = 0, 0.0
        for i in range(n_rays):
            if material[i] == m:
                d = dirs_cam[i]
                north[count] = origin[0] + (d[0] * rotation[0, 0] + d[1] * rotation[0, 1]
                                            + d[2] * rotation[0, 2]) * distance[i]
                east[count] = origin[1] + (d[0] * rotation[1, 0] + d[1] * rotation[1, 1]
                                           + d[2] * rotation[1, 2]) * distance[i]
                reach = max(reach, abs(north[count]), abs(east[count]))
                rows[count] = i
                count += 1
        c = ripples[m]
        if max(2.0 * abs(c[2]) * (1.5 * reach + abs(c[3])), 41.0 * reach + 11.0) < SINE_LIMIT:
            _ripple_rows(north[:count], east[:count], c, values)
        else:
            for j in range(count):
                values[j] = ripple_factor(north[j], east[j], c[0], c[1], c[2], c[3], c[4],
                                          c[5])
        for j in range(count):
            factor[rows[j]] = np.float32(values[j])
    return factor


def _veil_rays(distance, down, coefficient, x, z0, sun, water, total):  # type: ignore[no-untyped-def]
    """:func:`.formation.sun_veiling` per ray into ``total``: a ray into open water
    (x > 0) takes expm1(−∞) = −1; one that leaves upwards through it ends at the surface
    (``z0``: the camera's depth, m) and adds its radiance there. Zero without daylight
    (``sun`` 0). The exponentials in a flat loop of their own, which runs in SIMD lanes
    (:func:`_expm1`; written with its arguments, or in another loop shape, it does not)."""
    f32 = np.float32
    n = distance.shape[0]
    if sun == f32(0.0):
        total[:] = f32(0.0)
        return
    reach = np.empty(n, f32)  # where each ray's veil ends (m)
    exponent = np.empty(3 * n, f32)  # ray i, channel k at 3i + k
    for i in range(n):
        r = f32(distance[i])
        reach[i] = z0 / -down[i] if down[i] < f32(0.0) and not math.isfinite(r) else r
        for k in range(3):
            exponent[3 * i + k] = -x[i, k] * reach[i]
    for j in range(3 * n):
        exponent[j] = f32(_expm1(float(exponent[j])))
    for i in range(n):
        up_open = down[i] < f32(0.0) and not math.isfinite(distance[i])
        for k in range(3):
            term = exponent[3 * i + k] / x[i, k]
            term *= coefficient[i, k]
            term *= water[3, k]
            if up_open:
                term += sun * f32(math.exp(-water[0, k] * reach[i]))
            total[i, k] = term


def _light_rays(distance, material, normal, albedo_table, texture_kind, ripple,  # type: ignore[no-untyped-def]
                albedo_rows, dirs_cam, down, coefficient, x, cells, rotation, camera_z,
                sun_radiance, water, lamps, table, range_max, n_nodes, sun_half,
                forward_scatter, total, fs):
    """:func:`light_of_rays`' loop over the rays (see it and :mod:`.formation`)."""
    f32 = np.float32
    one, zero, inv_pi = f32(1.0), f32(0.0), f32(1.0 / math.pi)
    z0 = max(camera_z, 0.0)
    z_cam = f32(camera_z)
    r_max32, inv_r_max = f32(range_max), f32(1.0 / range_max)
    last_node = f32(n_nodes - 1)
    source = np.empty(3, np.float32)
    light = np.empty(3, np.float32)
    albedo = np.empty(3, np.float32)
    _veil_rays(distance, down, coefficient, x, f32(z0), f32(sun_radiance), water, total)
    for i in range(distance.shape[0]):
        r = f32(distance[i])
        for k in range(3):
            fs[i, k] = zero
        m = material[i]
        if m >= 0:
            kind = texture_kind[m]
            factor = one
            if kind == 1:  # sand ripples at the hit point (:func:`_ripple_factors`)
                factor = ripple[i]
            for k in range(3):
                if kind == 2:  # a picture: its texel, from numpy
                    albedo[k] = albedo_rows[i, k]
                else:
                    albedo[k] = albedo_table[m, k]
                    if kind == 1:
                        albedo[k] = min(max(albedo[k] * factor, zero), one)
                source[k] = albedo[k]
            n0, n1, n2 = f32(normal[i, 0]), f32(normal[i, 1]), f32(normal[i, 2])
            depth = down[i] * r + z_cam
            daylight = sun_half * (one + -n2)
            for k in range(3):
                level = f32(math.exp(-max(depth, zero) * water[1, k]))
                source[k] = source[k] * level * daylight
            if lamps.shape[0]:
                px = f32(dirs_cam[i, 0]) * r
                py = f32(dirs_cam[i, 1]) * r
                pz = f32(dirs_cam[i, 2]) * r
                nx = n0 * rotation[0, 0] + n1 * rotation[1, 0] + n2 * rotation[2, 0]
                ny = n0 * rotation[0, 1] + n1 * rotation[1, 1] + n2 * rotation[2, 1]
                nz = n0 * rotation[0, 2] + n1 * rotation[1, 2] + n2 * rotation[2, 2]
                for k in range(3):
                    light[k] = zero
                for j in range(lamps.shape[0]):
                    qx, qy, qz = px - lamps[j, 0], py - lamps[j, 1], pz - lamps[j, 2]
                    inv = one / f32(math.sqrt(qx * qx + qy * qy + qz * qz))
                    weight = lamps[j, 3] * inv * inv * f32(
                        math.exp(lamps[j, 4] * (qx * inv - one)))
                    weight *= max(-(nx * qx + ny * qy + nz * qz) * inv, zero)
                    for k in range(3):
                        light[k] += weight * f32(math.exp(-water[0, k] / inv))
                for k in range(3):
                    source[k] += albedo[k] * light[k] * inv_pi
            for k in range(3):
                direct = source[k] * f32(math.exp(-r * water[0, k]))
                if forward_scatter:
                    fs[i, k] = source[k] * f32(math.exp(-r * water[2, k])) - direct
                total[i, k] += direct
        if table.shape[0]:  # formation.lamp_backscatter
            rr = min(r if math.isfinite(r) else r_max32, r_max32)
            kf = f32(math.sqrt(rr * inv_r_max)) * last_node
            k0 = min(int(kf), n_nodes - 2)
            frac = float(kf) - k0
            row = cells[i] * n_nodes + k0
            for k in range(3):
                lo = table[row, k]
                total[i, k] += f32((table[row + 1, k] - lo) * frac) + lo
    return total


def _expose_pixels(radiance, gain, full_well, read_noise2, noise, lut, out):  # type: ignore[no-untyped-def]
    """:func:`expose`' loops over the flat values (see :func:`.formation.expose`): to the
    table's index in SIMD lanes, then the look-ups (one loop doing both ran a value at a
    time, 3.5x slower)."""
    f32 = np.float32
    one, zero = f32(1.0), f32(0.0)
    inv_fw = one / full_well
    top = f32(lut.shape[0] - 1)
    index = np.empty(radiance.shape[0], np.uint16)
    if noise.shape[0]:
        for i in range(radiance.shape[0]):
            signal = min(max(radiance[i] * gain, zero), one)
            sigma = f32(math.sqrt(signal * full_well + read_noise2)) * noise[i] * inv_fw
            signal = min(max(signal + sigma, zero), one)
            index[i] = np.uint16(signal * top + f32(0.5))
    else:
        for i in range(radiance.shape[0]):
            signal = min(max(radiance[i] * gain, zero), one)
            index[i] = np.uint16(signal * top + f32(0.5))
    for i in range(radiance.shape[0]):
        out[i] = lut[index[i]]
    return out


def _blur_index(range_img, scale, w0, idx_half):  # type: ignore[no-untyped-def]
    """:func:`forward_scatter`'s per-pixel pass: the blur σ = range·``scale`` (px; 0 for
    open water), the unblurred weight ``w0`` (H, W) of every pixel and the level index
    log2(max(σ, ½)) + 1 at the pixels cv2's INTER_NEAREST takes to ``idx_half`` (its
    grid (h, w)). Returns (largest σ, smallest and largest index kept)."""
    f32 = np.float32
    one, half = f32(1.0), f32(0.5)
    height, width = range_img.shape
    top = f32(0.0)
    for y in range(height):
        for x in range(width):
            r = range_img[y, x]
            sigma = (r if math.isfinite(r) else f32(0.0)) * scale
            top = max(top, sigma)
            if sigma <= half:  # log2(½) + 1 = 0
                w0[y, x] = one
            elif sigma >= one:  # log2(σ) + 1 ≥ 1
                w0[y, x] = f32(0.0)
            else:
                w0[y, x] = max(one - (f32(math.log2(sigma)) + one), f32(0.0))
    low, high = math.inf, -math.inf
    step_y, step_x = height / idx_half.shape[0], width / idx_half.shape[1]
    for i in range(idx_half.shape[0]):
        y = min(math.floor(i * step_y), height - 1)
        for j in range(idx_half.shape[1]):
            x = min(math.floor(j * step_x), width - 1)
            r = range_img[y, x]
            sigma = (r if math.isfinite(r) else f32(0.0)) * scale
            value = f32(math.log2(max(sigma, half))) + one
            idx_half[i, j] = value
            low, high = min(low, value), max(high, value)
    return float(top), low, high


def _blend_level(level, idx_half, k, top_index, blurred):  # type: ignore[no-untyped-def]
    """``blurred`` += ``level``·max(1 − |min(index, ``top_index``) − k|, 0) per pixel."""
    f32 = np.float32
    for i in range(level.shape[0]):
        for j in range(level.shape[1]):
            weight = max(f32(1.0) - abs(min(idx_half[i, j], top_index) - k), f32(0.0))
            for c in range(3):
                blurred[i, j, c] += level[i, j, c] * weight


def _linear_taps(n_out, n_in):  # type: ignore[no-untyped-def]
    """cv2's INTER_LINEAR taps from ``n_in`` samples to ``n_out``: per output index the
    two input indices and the float32 weight of the second (edges clamped)."""
    first, second = np.empty(n_out, np.int64), np.empty(n_out, np.int64)
    weight = np.empty(n_out, np.float32)
    scale = n_in / n_out
    for i in range(n_out):
        at = (i + 0.5) * scale - 0.5
        i0 = math.floor(at)
        w = np.float32(at - i0)
        if i0 < 0:
            i0, w = 0, np.float32(0.0)
        if i0 >= n_in - 1:
            i0, w = n_in - 1, np.float32(0.0)
        first[i], second[i], weight[i] = i0, min(i0 + 1, n_in - 1), w
    return first, second, weight


def _scatter_onto(light, blurred, source, w0, radiance):  # type: ignore[no-untyped-def]
    """``radiance`` = ``light`` + (``blurred`` resized bilinearly to the image as cv2's
    INTER_LINEAR does, + ``source``·``w0``), per pixel and channel."""
    one = np.float32(1.0)
    rows0, rows1, fys = _linear_taps(light.shape[0], blurred.shape[0])
    cols0, cols1, fxs = _linear_taps(light.shape[1], blurred.shape[1])
    for y in range(light.shape[0]):
        y0, y1, fy = rows0[y], rows1[y], fys[y]
        for x in range(light.shape[1]):
            x0, x1, fx = cols0[x], cols1[x], fxs[x]
            for c in range(3):
                top = blurred[y0, x0, c] * (one - fx) + blurred[y0, x1, c] * fx
                bottom = blurred[y1, x0, c] * (one - fx) + blurred[y1, x1, c] * fx
                scattered = top * (one - fy) + bottom * fy
                radiance[y, x, c] = light[y, x, c] + (scattered + source[y, x, c] * w0[y, x])


def _rotate_rows(rows, rotation, transposed, out):  # type: ignore[no-untyped-def]
    """``out`` = ``rows`` @ ``rotation``.T, or ``rows`` @ ``rotation`` if ``transposed``,
    each sum in numpy einsum's order for three terms: the same bits as
    ``einsum("ij,kj->ik")`` ((x·r₀ + z·r₂) + y·r₁) or ``einsum("ij,jk->ik")`` (in turn)."""
    for i in range(rows.shape[0]):
        x, y, z = rows[i, 0], rows[i, 1], rows[i, 2]
        for k in range(3):
            if transposed:
                out[i, k] = (x * rotation[0, k] + y * rotation[1, k]) + z * rotation[2, k]
            else:
                out[i, k] = (x * rotation[k, 0] + z * rotation[k, 2]) + y * rotation[k, 1]
    return out


@cache
def _compiled() -> tuple | None:
    """(:func:`_light_rays`, :func:`_expose_pixels`, :func:`_ripple_factors`) compiled,
    or None without numba."""
    light = jit_with(_light_rays, (_veil_rays, _expm1, _exp))
    exposure = jit(_expose_pixels)
    ripples = jit_with(_ripple_factors, (_sine, _ripple_rows, ripple_factor))
    scatter = (jit(_blur_index), jit(_blend_level), jit_with(_scatter_onto, (_linear_taps,)))
    return None if light is None else (light, exposure, ripples, scatter, jit(_rotate_rows))


def available() -> bool:
    """Whether the compiled kernels run (numba installed and not ``UHRISIM_NUMBA=0``)."""
    return _compiled() is not None


def light_of_rays(
    constants: OpticsConstants, distance: NDArray[np.float64], material: NDArray[np.int32],
    normal: NDArray[np.float64], albedo_table: NDArray[np.float32],
    textures: SceneTextures | None, albedo_rows: NDArray[np.float32] | None,
    dirs_cam: NDArray[np.float64], down: NDArray[np.float32],
    coefficient: NDArray[np.float32], x: NDArray[np.float32], cells: NDArray[np.int32],
    origin: NDArray[np.float64], rotation: NDArray[np.float64], sun_radiance: float,
    veil_scale: NDArray[np.float32],
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """(N, 3) radiance reaching the camera along N rays without forward scatter, and
    (N, 3) the forward-scatter source (zero where nothing was hit, or without forward
    scatter): what :meth:`.camera.UnderwaterCamera._light` forms with the numpy stages.

    Per ray: the hit's ``distance`` (m, inf: none), ``material`` (-1: none), NED
    ``normal``; the albedo from ``albedo_table`` by material, with the scene's sand
    ripples (``textures``) applied here, and a picture's texel from ``albedo_rows``
    (N, 3; needed where a hit is on a picture); camera-frame direction, the daylight
    paths' ``down``, ``coefficient``, ``x`` (:class:`.formation.DaylightPaths`) and the
    backscatter-table cell. ``origin`` (NED, m) and ``rotation`` (camera → NED): the
    camera's pose; ``veil_scale``: (3,) −L₀·exp(−K_d·z₀) of
    :func:`.formation.sun_veiling`."""
    kernel = _compiled()
    assert kernel is not None
    c = constants
    water = c.water.copy()
    water[3] = veil_scale
    n = len(distance)
    total, fs = np.empty((n, 3), _F32), np.empty((n, 3), _F32)
    rows = np.zeros((0, 3), _F32) if albedo_rows is None else albedo_rows
    if textures is None:
        kind, ripple = np.zeros(len(albedo_table) + 1, np.int8), np.ones(0, _F32)
    else:
        kind, ripple = textures.kind, np.empty(n, _F32)
        kernel[2](distance, material, kind, textures.ripples, dirs_cam, origin, rotation,
                  ripple)
    kernel[0](distance, material, normal, albedo_table, kind, ripple, rows, dirs_cam, down,
              coefficient, x, cells, rotation.astype(_F32), float(origin[2]),
              float(sun_radiance), water, c.lamps, c.table, c.range_max, c.n_nodes,
              c.sun_half, c.forward_scatter, total, fs)
    return total, fs


def with_forward_scatter(light: NDArray[np.float32], source: NDArray[np.float32],
                         range_img: NDArray[np.float32], water: WaterOptics, spread: float,
                         focal_px: float) -> NDArray[np.float32]:
    """``light`` + :func:`.formation.forward_scatter` of ``source`` ((H, W, 3) each), its
    steps (the Gaussian pyramid by cv2, the same levels and weights) with the per-pixel
    passes at full resolution compiled: the blur index and unblurred weight, and the
    blurred levels brought back to full size (bilinear, as cv2) and added to the light.
    Within a few float32 units in the last place of the numpy stages (libm's log2, the
    bilinear sums in another order)."""
    h, w = source.shape[:2]
    if min(h, w) < 4:
        return light + fm.forward_scatter(source, range_img, water, spread, focal_px)
    kernels = _compiled()
    assert kernels is not None
    blur_index, blend_level, scatter_onto = kernels[3]
    half = cv2.pyrDown(source)
    w0 = np.empty((h, w), _F32)
    idx_half = np.empty(half.shape[:2], _F32)
    top, low, high = blur_index(range_img, _F32(spread * float(water.b[1]) * focal_px), w0,
                                idx_half)
    if top < 0.5:
        return light + source
    n_levels = min(fm.FS_LEVELS, math.ceil(math.log2(top)) + 2)
    top_index = _F32(n_levels - 1.0)
    blurred = np.zeros_like(half)
    small = half
    for k in range(1, n_levels):
        if k > 1:
            small = cv2.pyrDown(small) if min(small.shape[:2]) >= 2 else small
        if k >= min(high, top_index) + 1.0 or k <= low - 1.0:
            continue  # no pixel weighs this level
        level = small if k == 1 else cv2.resize(small, half.shape[1::-1],
                                                interpolation=cv2.INTER_LINEAR)
        blend_level(level, idx_half, _F32(k), top_index, blurred)
    radiance = np.empty_like(light)
    scatter_onto(light, blurred, source, w0, radiance)
    return radiance


def rotated(rows: NDArray[np.float64], rotation: NDArray[np.float64],
            transposed: bool = False) -> NDArray[np.float64]:
    """(N, 3) ``rows`` turned by ``rotation`` (rows @ rotation.T; ``transposed``:
    rows @ rotation), compiled: the bits of numpy's ``einsum("ij,kj->ik", rows,
    rotation)`` (``"ij,jk->ik"``; ``tests/unit/test_camera_fused.py``), at a fifth of its
    cost."""
    kernels = _compiled()
    assert kernels is not None
    return kernels[4](rows, rotation, transposed, np.empty(rows.shape))


def expose(radiance: NDArray[np.float32], gain: float, config: CameraConfig,
           noise: NDArray[np.float32] | None, lut: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """:func:`.formation.expose` compiled (the same bytes)."""
    kernel = _compiled()
    assert kernel is not None
    flat = np.ascontiguousarray(radiance).reshape(-1)
    draws = np.zeros(0, _F32) if noise is None else np.ascontiguousarray(noise).reshape(-1)
    out = np.empty(flat.shape, np.uint8)
    kernel[1](flat, _F32(gain), _F32(config.full_well_e), _F32(config.read_noise_e) ** 2,
              draws, lut, out)
    return out.reshape(radiance.shape)
