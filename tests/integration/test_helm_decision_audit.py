"""Decision audit: the helm decides as it did before its hot paths were compiled and
reused (tests/data/helm/mission_decisions.npz: every decision of the paper's mission,
600 s, both helms). Every one of the 4 800 decisions must be equal, bit for bit; and the
compiled pieces (numba, ``uhrisim[fast]``) equal the numpy ones they stand in for."""

import importlib
import runpy
from pathlib import Path

import numpy as np
import pytest

from uhrisim.autonomy import coupler, cpa, ivp_build, solver, zaic
from uhrisim.autonomy.domain import Domain, DomainAxis, Objective

DATA = Path(__file__).resolve().parents[1] / "data" / "helm"


@pytest.mark.slow
def test_every_decision_of_the_paper_s_mission_is_today_s():
    reference = np.load(DATA / "mission_decisions.npz")["decisions"]
    maker = runpy.run_path(str(DATA / "make_mission_decisions.py"))
    decisions = maker["mission_decisions"]()
    assert decisions.shape == reference.shape == (4800, 5)
    differ = ~((decisions == reference) | (np.isnan(decisions) & np.isnan(reference)))
    rows = np.flatnonzero(differ.any(axis=1))
    assert rows.size == 0, f"{rows.size} decisions differ, first: {decisions[rows[:3]]} " \
                           f"instead of {reference[rows[:3]]}"


#: The helm's compiled kernels, each remembered by its module once built.
KERNELS = (ivp_build._compiled_reflect, ivp_build._compiled_reflect_cpa, cpa._compiled_points,
           coupler._compiled_couple, zaic._compiled_peak, solver._compiled_add_weighted)


def _forget_kernels():
    importlib.import_module("uhrisim.core.compiled").numba_module.cache_clear()
    for cached in KERNELS:
        cached.cache_clear()


def _numpy_only(monkeypatch):
    """Run the helm's pieces without numba (the pure-numpy path)."""
    monkeypatch.setenv("UHRISIM_NUMBA", "0")
    _forget_kernels()


def test_compiled_helm_kernels_equal_numpy_bit_for_bit(monkeypatch):
    pytest.importorskip("numba", reason="the [fast] extra is not installed")
    rng = np.random.default_rng(8)
    grid = cpa.CpaGrid.over(np.arange(360.0), np.linspace(0.0, 2.0, 41))
    tables = [rng.uniform(0.0, 100.0, (360, 41)),
              np.cumsum(rng.normal(size=(360, 26)), axis=0)]
    pieces = [(3, 3), (3, 2), (9, 6)]
    situations = [(*rng.normal(0.0, 20.0, 4), rng.uniform(0, 360), rng.uniform(0, 2), 120.0)
                  for _ in range(20)]

    axes = [DomainAxis("course", 0.0, 359.0, 360, wrap=True), DomainAxis("speed", 0.0, 2.0, 41)]
    peaks = [(rng.uniform(-30.0, 400.0), *rng.choice([0.0, 1e-10, 0.1, 30.0, 200.0], 3),
              *sorted(rng.uniform(-10.0, 120.0, 2))) for _ in range(30)]
    peaks += [(361.5, 0.0, 0.0, 0.0, 0.0, 100.0), (-1.0, 0.0, 0.0, 0.0, 0.0, 100.0)]  # insisted

    domain = Domain(tuple(axes))
    weighted = [solver.WeightedObjective(f"f{k}", rng.uniform(1.0, 300.0),  # span 0..300:
                                         Objective(("course", "speed"), tables[0] * k))  # some
                for k in (1.7, 0.4, 0.9, 2.6)]  # renormalised by the solver

    def made():  # tables, CPAs, utilities, couplings, peaks and sums, (min, max) of the tables
        reflected = [ivp_build.reflect_ranged(t, p) for t in tables for p in pieces]
        reflected += [ivp_build.reflect_cpa(grid, *s, u, p) for s in situations[:4] for p in pieces
                      for u in (cpa.AvoidUtility(8.0, 25.0), cpa.CutRangeUtility(12.5))]
        coupled = [coupler._couple(t[:, 0], t[0], *w, n) for t in [*tables, np.ones((3, 4))]
                   for w in ((50.0, 50.0), (20.0, 80.0)) for n in (True, False)]
        return ([r[0] for r in reflected] + [c[0] for c in coupled]
                + [zaic.zaic_peak_on_axis(a, *p) for a in axes for p in peaks]
                + [solver._fuse(domain, ("course", "speed"), solver._taking_part(weighted[:k]))
                   for k in (1, 2, 4)],
                [grid.distance(*s) for s in situations],
                [grid.distance(*s, cpa.AvoidUtility(8.0, 25.0)) for s in situations]
                + [grid.distance(*s, cpa.CutRangeUtility(12.5)) for s in situations],
                [r[1:] for r in reflected + coupled])

    compiled = made()
    _numpy_only(monkeypatch)
    numpy = made()
    flat = [[a for group in made_ for a in group] for made_ in (compiled[:3], numpy[:3])]
    for fast, slow in zip(*flat, strict=True):
        np.testing.assert_array_equal(fast, slow)
    assert compiled[3] == numpy[3] == [(t.min(), t.max()) for t in numpy[0][:len(numpy[3])]]
    monkeypatch.delenv("UHRISIM_NUMBA")
    _forget_kernels()
