"""Sea floors: closed-form depths, depth_at == the mesh the rays see, files, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.core.errors import AssetError, ConfigError
from uhrisim.world import seafloor as sf
from uhrisim.world.materials import SAND
from uhrisim.world.scene import Scene


def _vertical_ray_depths(floor: sf.SeaFloor, n: np.ndarray, e: np.ndarray) -> np.ndarray:
    scene = Scene()
    scene.add_static(floor, "seafloor", SAND)
    o = np.column_stack([n, e, np.full(len(n), -1.0)])
    d = np.tile([0.0, 0.0, 1.0], (len(n), 1))
    return scene.raycaster().cast(o, d, 100.0).distance - 1.0


def test_flat_and_sloped_closed_form() -> None:
    f = sf.flat(7.5, 30.0)
    assert f.depth_at(3.0, -4.0) == 7.5
    assert math.isnan(f.depth_at(31.0, 0.0))
    # depth = d0 + slope * (n cos h + e sin h), deeper towards the compass direction h.
    s = sf.sloped(6.0, 0.05, direction_deg=90.0, extent=(-20.0, 20.0, -20.0, 20.0))
    np.testing.assert_allclose(s.depth_at([0.0, 5.0, 0.0], [0.0, 0.0, 10.0]), [6.0, 6.0, 6.5])
    s2 = sf.sloped(6.0, 0.1, direction_deg=30.0, extent=20.0)
    n, e = 4.0, -3.0
    expected = 6.0 + 0.1 * (n * math.cos(math.radians(30)) + e * math.sin(math.radians(30)))
    assert s2.depth_at(n, e) == pytest.approx(expected, abs=1e-12)


@pytest.mark.parametrize("depth", [7.5, 0.0, -0.0])
def test_one_points_depth_on_a_flat_floor_is_the_interpolations(depth) -> None:
    """One point's depth on a flat floor skips the interpolation (the boots' walk asks
    ~64 000 times a mission): the same bits as the grid's interpolation (arrays)."""
    f = sf.SeaFloor(np.array([-20.0, -3.0, 20.0]), np.array([-10.0, 10.0]),
                    np.full((3, 2), depth))
    rng = np.random.default_rng(1)
    n = np.concatenate([rng.uniform(-21.0, 21.0, 200), [-20.0, 20.0, -3.0, math.nan]])
    e = np.concatenate([rng.uniform(-11.0, 11.0, 200), [-10.0, 10.0, 10.0, 0.0]])
    grid = f.depth_at(n, e)
    one = np.array([f.depth_at(float(a), float(b)) for a, b in zip(n, e, strict=True)])
    assert np.array_equal(np.signbit(one), np.signbit(grid))
    np.testing.assert_array_equal(one, grid)
    assert np.isnan(one).sum() == np.isnan(grid).sum() > 0


def test_depth_at_matches_ray_hits_on_rough_floor() -> None:
    floor = sf.procedural(42, (-10.0, 10.0, -8.0, 8.0), 8.0, 0.5, 2.0, 0.7)
    rng = np.random.default_rng(0)
    n, e = rng.uniform(-9.9, 9.9, 500), rng.uniform(-7.9, 7.9, 500)
    np.testing.assert_allclose(_vertical_ray_depths(floor, n, e), floor.depth_at(n, e), atol=1e-9)
    # The scalar path (two plain numbers) gives the vectorized answer exactly.
    scalar = [floor.depth_at(float(a), float(b)) for a, b in zip(n[:50], e[:50], strict=True)]
    np.testing.assert_array_equal(scalar, floor.depth_at(n[:50], e[:50]))
    # At grid nodes the depth is the grid value.
    np.testing.assert_allclose(
        floor.depth_at(floor.north[3], floor.east[:5]), floor.depth[3, :5], atol=1e-12
    )


def test_procedural_is_deterministic_with_requested_statistics() -> None:
    a = sf.procedural(5, 40.0, mean_depth=9.0, roughness=0.3, correlation_length=4.0)
    b = sf.procedural(5, 40.0, mean_depth=9.0, roughness=0.3, correlation_length=4.0)
    c = sf.procedural(6, 40.0, mean_depth=9.0, roughness=0.3, correlation_length=4.0)
    np.testing.assert_array_equal(a.depth, b.depth)
    assert not np.array_equal(a.depth, c.depth)
    assert a.depth.mean() == pytest.approx(9.0, abs=1e-12)
    assert a.depth.std() == pytest.approx(0.3, rel=1e-12)
    # Smooth: neighbouring 1 m cells differ much less than the 0.3 m rms relief.
    assert np.abs(np.diff(a.depth, axis=0)).mean() < 0.1
    flat = sf.procedural(5, 10.0, mean_depth=9.0, roughness=0.0)
    assert np.all(flat.depth == 9.0)


@pytest.mark.parametrize("suffix", [".npy", ".csv"])
def test_from_height_grid_round_trip(tmp_path, suffix: str) -> None:
    grid = 6.0 + np.add.outer(np.arange(4) * 0.5, np.arange(5) * 0.1)
    path = tmp_path / f"bathy{suffix}"
    if suffix == ".npy":
        np.save(path, grid)
    else:
        np.savetxt(path, grid, delimiter=",")
    floor = sf.from_height_grid(path, spacing=(2.0, 1.0), origin_ned=(10.0, -2.0))
    np.testing.assert_allclose(floor.north, [10.0, 12.0, 14.0, 16.0])
    np.testing.assert_allclose(floor.east, [-2.0, -1.0, 0.0, 1.0, 2.0])
    # The grid is planar here (depth linear in i and j), so any point is exact:
    # depth = 6 + 0.5 (n - 10) / 2 + 0.1 (e + 2).
    n, e = 13.3, 0.7
    assert floor.depth_at(n, e) == pytest.approx(6.0 + 0.25 * (n - 10.0) + 0.1 * (e + 2.0))
    assert len(floor.mesh.faces) == 2 * 3 * 4


def test_height_grid_errors_name_the_file(tmp_path) -> None:
    with pytest.raises(AssetError, match=r"missing\.npy: height grid file not found"):
        sf.from_height_grid(tmp_path / "missing.npy", 1.0)
    bad = tmp_path / "bad.csv"
    bad.write_text("1,2\n3,nan\n")
    with pytest.raises(AssetError, match=r"bad\.csv: height grid contains NaN"):
        sf.from_height_grid(bad, 1.0)
    junk = tmp_path / "junk.npy"
    junk.write_bytes(b"\x00garbage" * 10)
    with pytest.raises(AssetError, match=r"junk\.npy: cannot read height grid") as exc:
        sf.from_height_grid(junk, 1.0)
    assert "\n" not in str(exc.value)
    one_d = tmp_path / "line.npy"
    np.save(one_d, np.arange(5.0))
    with pytest.raises(AssetError, match=r"line\.npy: height grid must be a 2-D"):
        sf.from_height_grid(one_d, 1.0)
    with pytest.raises(ConfigError, match="extent"):
        sf.flat(8.0, (0.0, -1.0, 0.0, 1.0))



def test_max_slope_bounds_the_floor_anywhere_near_a_point():
    assert sf.flat(12.0, 50.0).max_slope == 0.0
    assert sf.sloped(10.0, 0.25, direction_deg=30.0, extent=20.0).max_slope == pytest.approx(0.25)
    floor = sf.procedural(4, extent=20.0, roughness=0.5, correlation_length=2.0)
    # the depth changes by at most max_slope times the horizontal distance
    rng = np.random.default_rng(0)
    a = rng.uniform(-15, 15, (500, 2))
    b = a + rng.normal(0.0, 0.5, (500, 2))
    dz = np.abs(floor.depth_at(b[:, 0], b[:, 1]) - floor.depth_at(a[:, 0], a[:, 1]))
    assert floor.max_slope > 0.05
    assert np.all(dz <= floor.max_slope * np.linalg.norm(b - a, axis=1) + 1e-9)
