"""The batched cast of N sensors' fans (EmbreeRayCaster.cast_fans, the sonar vector env's
one query a step): each fan's hits are those of its own cast with the body posed for it,
and rays it is given unchecked (a sensor's own) are the same rays."""

from __future__ import annotations

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.world import seafloor as sf
from uhrisim.world.assets import diver_parts
from uhrisim.world.bodies import ArticulatedMesh
from uhrisim.world.materials import NEOPRENE, SAND
from uhrisim.world.raycast import (
    _compiled_fan_sphere_rays,
    _fan_spans,
    _fan_sphere_rays,
    _RayCuller,
)
from uhrisim.world.scene import Scene

RANGE_M = 20.0


def _fans(rng: np.random.Generator, n_fans: int, n_rays: int):
    """Fans looking about at a diver at the origin (depth 4 m) from 2-8 m away, each
    diver posed its own way (heading, a little offset, kick phase)."""
    bearing = rng.uniform(0.0, 2.0 * np.pi, n_fans)
    distance = rng.uniform(2.0, 8.0, n_fans)
    origins = np.stack([distance * np.cos(bearing), distance * np.sin(bearing),
                        rng.uniform(3.0, 5.0, n_fans)], axis=1)
    look = np.array([0.0, 0.0, 4.0]) - origins
    look /= np.linalg.norm(look, axis=1, keepdims=True)
    dirs = look[:, None, :] + rng.normal(0.0, 0.25, (n_fans, n_rays, 3))
    dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
    poses = np.zeros((n_fans, 4, 4))
    poses[:, 3, 3] = 1.0
    poses[:, :3, :3] = [rot_z(y) for y in rng.uniform(-np.pi, np.pi, n_fans)]
    poses[:, :3, 3] = np.c_[rng.normal(0.0, 0.3, (n_fans, 2)), np.full(n_fans, 4.0)]
    return origins, dirs, poses, rng.uniform(0.0, 2.0 * np.pi, n_fans)


@pytest.fixture(scope="module")
def scene() -> Scene:
    scene = Scene()
    scene.add_static(sf.flat(6.0, 40.0), "seafloor", SAND)
    scene.add_dynamic("diver", diver_parts(NEOPRENE), "diver", NEOPRENE)
    return scene


def test_each_fan_hits_what_its_own_cast_hits(scene: Scene) -> None:
    caster = scene.raycaster("embree")
    origins, dirs, poses, phases = _fans(np.random.default_rng(4), 6, 3000)
    together = caster.cast_fans(origins, dirs, RANGE_M, {"diver": (poses, phases)},
                                checked=False)
    n = dirs.shape[1]
    on_diver = 0
    for i in range(len(origins)):
        scene.set_pose("diver", poses[i, :3, 3], poses[i, :3, :3], phases[i])
        alone = caster.cast(origins[i], dirs[i], RANGE_M)
        rows = slice(i * n, (i + 1) * n)
        np.testing.assert_array_equal(together.label[rows], alone.label)
        np.testing.assert_array_equal(together.body[rows], alone.body)
        np.testing.assert_allclose(together.distance[rows], alone.distance, rtol=0, atol=1e-9)
        np.testing.assert_allclose(together.normal[rows], alone.normal, rtol=0, atol=1e-9)
        on_diver += int(np.count_nonzero(alone.body >= 0))
    assert on_diver > 500  # the fans saw the diver (and the sea floor beyond)
    checked = caster.cast_fans(origins, dirs, RANGE_M, {"diver": (poses, phases)})
    for field in ("distance", "label", "normal", "body"):
        np.testing.assert_array_equal(getattr(checked, field), getattr(together, field))


def test_rays_given_checked_are_still_refused_when_bad(scene: Scene) -> None:
    origins, dirs, poses, phases = _fans(np.random.default_rng(5), 2, 10)
    dirs[1, 3] *= 2.0
    with pytest.raises(ConfigError, match="unit vectors"):
        scene.raycaster("embree").cast_fans(origins, dirs, RANGE_M, {"diver": (poses, phases)})


def test_fan_spans_are_each_fan_s_least_and_greatest_components() -> None:
    d = np.random.default_rng(6).normal(size=(5, 700, 3))
    lo, hi = _fan_spans(d)
    np.testing.assert_array_equal(lo, d.min(axis=1))
    np.testing.assert_array_equal(hi, d.max(axis=1))


def test_fan_sphere_pass_picks_the_rays_the_ray_culler_picks() -> None:
    """The fans' bounding-sphere pass (whole fans, and one ray per row) is
    :class:`_RayCuller`'s test: per fan, the same rays, some just inside or outside a
    sphere whose radius is a ray's miss distance."""
    rng = np.random.default_rng(11)
    origins, dirs, _, _ = _fans(rng, 6, 400)
    centres = origins + rng.normal(0.0, 3.0, (6, 3))
    v = centres[:, None, :] - origins[:, None, :]
    tca = np.einsum("nrk,nk->nr", dirs, v[:, 0])
    miss = np.sqrt(np.maximum(np.einsum("nk,nk->n", v[:, 0], v[:, 0])[:, None] - tca**2, 0))
    radii = np.median(miss, axis=1)  # half of each fan's rays pass within the radius
    limit = rng.uniform(0.5, 12.0, 6 * 400)
    expected = [f * 400 + _RayCuller(origins[f], dirs[f]).candidates(
        limit[f * 400:(f + 1) * 400], centres[f], radii[f]) for f in (0, 2, 3, 5)]
    sphere_rays = _compiled_fan_sphere_rays() or _fan_sphere_rays
    rows = np.empty(6 * 400, dtype=np.int64)
    count = sphere_rays(np.array([0, 2, 3, 5]), 400, origins, dirs.reshape(-1, 3), limit,
                        centres, radii, rows)
    np.testing.assert_array_equal(rows[:count], np.concatenate(expected))
    assert 0 < count < 4 * 400
    per_row = np.concatenate(expected)
    count = sphere_rays(per_row // 400, 0, origins, dirs.reshape(-1, 3)[per_row],
                        limit[per_row], centres, radii, rows)
    np.testing.assert_array_equal(rows[:count], np.arange(len(per_row)))


def test_parts_posed_for_many_phases_at_once_are_each_phase_s() -> None:
    """The fans' bodies are posed for all their kick phases at once: the same transforms,
    bit for bit, as one phase at a time."""
    body = ArticulatedMesh.from_any(diver_parts(NEOPRENE))
    phases = np.r_[np.random.default_rng(7).uniform(-40.0, 40.0, 500), 0.0, np.pi]
    np.testing.assert_array_equal(body.part_transforms_many(phases),
                                  [body.part_transforms(float(k)) for k in phases])
