"""pHelmIvP's piecewise build of (course, speed) functions, held to the real MOOS-IvP.

tests/data/helm/ivp_reflector.npz (provenance in its README) holds tables given to
MOOS-IvP's OF_Reflector and what the built IvP function was worth at every grid point;
the fit must reproduce those values exactly, and the vectorised fit its plain reference.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uhrisim.autonomy.cpa import AvoidUtility, CpaGrid, CutRangeUtility
from uhrisim.autonomy.ivp_build import (
    fit_pieces,
    fit_pieces_reference,
    normalize,
    reflect,
    reflect_cpa,
    reflect_ranged,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "helm" / "ivp_reflector.npz"
CASES = [("avoid_3x3_26", (3, 3)), ("avoid_3x3_41", (3, 3)), ("cpa_3x2_26", (3, 2))]


@pytest.mark.parametrize(("case", "piece"), CASES)
def test_fit_equals_moos_ivp_bit_for_bit(case: str, piece: tuple[int, int]):
    data = np.load(DATA)
    exact, ivp = data[f"{case}_exact"], data[f"{case}_ivp"]
    built = normalize(fit_pieces(exact, piece)).table()
    np.testing.assert_array_equal(built, ivp)
    assert np.abs(exact - ivp).max() > 25.0  # the fit is not the exact table: it matters


@pytest.mark.parametrize("shape", [(360, 26), (10, 7), (4, 1), (1, 5), (8, 101)])
@pytest.mark.parametrize("piece", [(3, 3), (3, 2), (1, 1), (4, 5)])
def test_vectorised_fit_equals_reference(shape: tuple[int, int], piece: tuple[int, int]):
    rng = np.random.default_rng(sum(shape) * 10 + piece[0] + piece[1])
    values = rng.uniform(-5.0, 120.0, shape)
    values[rng.uniform(size=shape) < 0.3] = 100.0  # plateaus, as a clipped utility has
    fast, ref = fit_pieces(values, piece), fit_pieces_reference(values, piece)
    for name in ("b", "mc", "ms"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(ref, name))
    np.testing.assert_array_equal(fast.table(), ref.table())


@pytest.mark.parametrize("shape", [(10, 7), (4, 1), (1, 5), (2, 2)])
def test_reflected_table_and_range_equal_the_numpy_build(shape: tuple[int, int]):
    """reflect_ranged and reflect_cpa (compiled with numba: the pieces' samples, one column
    a piece) on grids with single-index and cut-short pieces along both axes."""
    rng = np.random.default_rng(shape[0] * 10 + shape[1])
    values = rng.uniform(-5.0, 120.0, shape)
    values[rng.uniform(size=shape) < 0.3] = 100.0
    grid = CpaGrid.over(np.linspace(0.0, 350.0, shape[0]), np.linspace(0.0, 2.0, shape[1]))
    for piece in [(3, 3), (3, 2), (1, 1), (4, 5), (2, 1)]:
        table, lo, hi = reflect_ranged(values, piece)
        numpy = normalize(normalize(fit_pieces(values, piece))).table()
        np.testing.assert_array_equal(table, numpy)
        assert (lo, hi) == (numpy.min(), numpy.max())
        for utility in (AvoidUtility(8.0, 25.0), CutRangeUtility(12.5)):
            situation = (3.0, -4.0, 10.0, 2.0, 200.0, 0.8, 60.0)
            built = reflect_cpa(grid, *situation, utility, piece)
            expected = reflect_ranged(grid.distance(*situation, utility), piece)
            np.testing.assert_array_equal(built[0], expected[0])
            assert built[1:] == expected[1:]


def test_pieces_cover_the_grid_with_the_last_one_cut_short():
    f = fit_pieces(np.zeros((360, 26)), (3, 3))
    assert (len(f.c_lo), len(f.s_lo)) == (120, 9)  # BuildUtils: 120 x 9 = 1080 pieces
    assert (f.s_lo[-1], f.s_hi[-1]) == (24, 25)
    assert f.table().shape == (360, 26)


def test_a_plane_is_fitted_exactly_and_a_single_point_piece_is_its_value():
    c, s = np.meshgrid(np.arange(9.0), np.arange(7.0), indexing="ij")
    plane = 3.0 + 0.5 * c - 2.0 * s
    np.testing.assert_allclose(fit_pieces(plane, (3, 3)).table(), plane, atol=1e-12)
    spike = np.zeros((1, 1)) + 42.0
    assert fit_pieces(spike, (3, 3)).table()[0, 0] == 42.0


def test_intercept_is_clamped_to_the_samples_range():
    # corners 0, 0, 0, 0 and a centre of 100: the mean (20) stays, within [0, 100]
    v = np.zeros((3, 3))
    v[1, 1] = 100.0
    assert fit_pieces(v, (3, 3)).b[0, 0] == 20.0
    # a steep plateau edge: the plane through the corner differences overshoots the
    # samples' top at the corners, so the intercept is pulled down to keep it <= max
    v = np.array([[0.0, 100.0, 100.0], [0.0, 100.0, 100.0], [100.0, 100.0, 100.0]])
    f = fit_pieces(v, (3, 3))
    assert f.table().max() <= 100.0 + 1e-12


def test_normalize_maps_onto_the_range_and_leaves_a_constant_alone():
    f = fit_pieces(np.linspace(10.0, 60.0, 36).reshape(6, 6), (3, 3))
    t = normalize(f, 0.0, 100.0).table()
    assert (t.min(), t.max()) == pytest.approx((0.0, 100.0))
    flat = fit_pieces(np.full((6, 6), 37.0), (3, 3))
    np.testing.assert_array_equal(normalize(flat).table(), 37.0)  # PDMap.cpp:175-176
    np.testing.assert_array_equal(reflect(np.full((6, 6), 37.0), (3, 3)), 37.0)
