"""Scene and ray casting: closed-form distances, static/dynamic separation, exclude,
validation, collision sweeps and the paper scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.core.frames import rot_z
from uhrisim.core.rng import component_rng
from uhrisim.world import primitives as prim
from uhrisim.world import seafloor as sf
from uhrisim.world.assets import diver_parts
from uhrisim.world.materials import CONCRETE, NEOPRENE, SAND, STEEL, Material
from uhrisim.world.paper_scenes import add_diver, pier_scene, single_piling_scene, torus_scene
from uhrisim.world.scene import Scene

BACKENDS = ["embree", "reference"]


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.mark.parametrize("backend", BACKENDS)
def test_plane_distance_closed_form(backend: str) -> None:
    # Flat floor z = D; a ray from depth z0 with direction d (d_z > 0) hits at (D - z0)/d_z.
    depth, z0 = 8.0, 3.0
    scene = Scene()
    scene.add_static(sf.flat(depth, 200.0), "seafloor", SAND)
    rng = component_rng(1, "tests/plane")
    d = _unit(rng.standard_normal((300, 3)))
    d[:, 2] = np.abs(d[:, 2]) + 0.05
    d = _unit(d)
    o = np.column_stack([rng.uniform(-5, 5, 300), rng.uniform(-5, 5, 300), np.full(300, z0)])
    h = scene.raycaster(backend).cast(o, d, 1000.0)
    expected = (depth - z0) / d[:, 2]
    inside = np.all(np.abs((o + d * expected[:, None])[:, :2]) < 200.0, axis=1)
    np.testing.assert_allclose(h.distance[inside], expected[inside], atol=1e-9)
    np.testing.assert_allclose(h.normal[inside], np.tile([0.0, 0.0, -1.0], (inside.sum(), 1)))
    assert np.all(h.reflectivity[inside] == SAND.reflectivity)
    assert np.all(h.label[inside] == scene.label_id("seafloor"))
    # Rays pointing up (towards the surface) miss: the scene has no surface mesh.
    up = scene.raycaster(backend).cast(o, -d, 1000.0)
    assert not np.any(up.hit)


@pytest.mark.parametrize("backend", BACKENDS)
def test_box_face_distance_closed_form(backend: str) -> None:
    # Box centred at c, size s, yawed 30°. Rays from the box frame's -x side towards the
    # -x face: t = (face offset along the face normal) / (d · face normal).
    c, s, yaw = np.array([10.0, 2.0, 4.0]), np.array([1.0, 2.0, 3.0]), math.radians(30.0)
    scene = Scene()
    scene.add_static(prim.box(s, c, yaw=yaw), "box", CONCRETE)
    rot = rot_z(yaw)
    n_face = -rot[:, 0]  # outward normal of the -x face
    face_centre = c + n_face * s[0] / 2
    rng = component_rng(2, "tests/box")
    targets = (
        face_centre
        + rng.uniform(-0.45, 0.45, (200, 1)) * s[1] * rot[:, 1]
        + rng.uniform(-0.45, 0.45, (200, 1)) * s[2] * rot[:, 2]
    )
    o = face_centre + 5.0 * n_face + rng.uniform(-1, 1, (200, 3))
    d = _unit(targets - o)
    h = scene.raycaster(backend).cast(o, d, 50.0)
    expected = np.einsum("ij,j->i", face_centre - o, n_face) / (d @ n_face)
    np.testing.assert_allclose(h.distance, expected, atol=1e-9)
    np.testing.assert_allclose(h.normal, np.tile(n_face, (200, 1)), atol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_sphere_distance_between_circumscribed_and_inscribed(backend: str) -> None:
    # An icosphere's vertices lie on radius r; its faces are at least r_in from the centre.
    # A ray hitting the mesh must therefore hit between the exact ray-sphere distances for
    # r (closed form) and r_in (when it hits that sphere).
    c, r = np.array([6.0, -1.0, 4.0]), 1.0
    mesh = prim.sphere(r, c, subdivisions=3)
    n = mesh.face_normals
    r_in = float(np.min(np.einsum("ij,ij->i", mesh.triangles[:, 0] - c, n)))
    assert 0.98 < r_in < r  # tessellation error of a 1280-face icosphere
    scene = Scene()
    scene.add_static(mesh, "ball", STEEL)
    rng = component_rng(3, "tests/sphere")
    o = c + np.array([-5.0, 0.0, 0.0]) + rng.uniform(-0.5, 0.5, (400, 3))
    d = _unit(c + rng.uniform(-0.9, 0.9, (400, 3)) - o)
    h = scene.raycaster(backend).cast(o, d, 50.0)

    def ray_sphere(radius: float) -> np.ndarray:
        oc = o - c
        b = np.einsum("ij,ij->i", oc, d)
        disc = b * b - (np.einsum("ij,ij->i", oc, oc) - radius * radius)
        return np.where(disc >= 0, -b - np.sqrt(np.maximum(disc, 0)), np.inf)

    t_out, t_in = ray_sphere(r), ray_sphere(r_in)
    hit_in = np.isfinite(t_in)
    assert hit_in.sum() > 300
    assert np.all(h.hit[hit_in])
    assert np.all(h.distance[hit_in] >= t_out[hit_in] - 1e-9)
    assert np.all(h.distance[hit_in] <= t_in[hit_in] + 1e-9)
    # Normals are unit and face the ray; rays through the centre hit at |c - o| - r_in..r.
    assert np.allclose(np.linalg.norm(h.normal[h.hit], axis=1), 1.0)
    assert np.all(np.einsum("ij,ij->i", h.normal[h.hit], d[h.hit]) < 0)


@pytest.mark.parametrize("backend", BACKENDS)
def test_max_range_and_inside_hits(backend: str) -> None:
    scene = Scene()
    scene.add_static(prim.box((2.0, 2.0, 2.0), (10.0, 0.0, 0.0)), "box", STEEL)
    o = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    d = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    rc = scene.raycaster(backend)
    h = rc.cast(o, d, 9.0)  # face at x = 9: a hit at exactly max_range counts
    np.testing.assert_allclose(h.distance, [9.0, 9.0, 1.0])
    h = rc.cast(o, d, 8.999)
    assert list(h.hit) == [False, False, True]
    assert h.label[0] == -1 and h.reflectivity[0] == 0.0 and np.all(h.normal[0] == 0.0)
    # From inside the box the inner face is hit, its normal turned to face the origin.
    np.testing.assert_allclose(h.normal[2], [0.0, -1.0, 0.0])
    h = rc.cast(o, d, np.inf)
    assert h.hit.all()


def _separation_scene() -> Scene:
    scene = Scene()
    scene.add_static(sf.flat(8.0, 40.0), "seafloor", SAND)
    for e in (-2.0, 2.0):
        scene.add_static(prim.box((0.4, 0.4, 9.0), (12.0, e, 4.0)), "piling", CONCRETE)
    scene.add_dynamic("ball", prim.sphere(0.5), "diver", NEOPRENE, (6.0, 0.0, 4.0))
    return scene


def _fan(n_az: int = 64, n_el: int = 16, origin=(0.0, 0.0, 4.0)):
    az = np.radians(np.linspace(-30, 30, n_az))
    el = np.radians(np.linspace(-10, 20, n_el))
    a, e = np.meshgrid(az, el)
    d = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1).reshape(-1, 3)
    return np.tile(origin, (len(d), 1)), d


@pytest.mark.parametrize("backend", BACKENDS)
def test_moving_a_body_leaves_static_hits_identical(backend: str) -> None:
    scene = _separation_scene()
    rc = scene.raycaster(backend)
    o, d = _fan()
    before = rc.cast(o, d, 40.0)
    scene.set_pose("ball", (6.0, 3.0, 4.0), np.eye(3))
    after = rc.cast(o, d, 40.0)
    on_ball = (before.body == 0) | (after.body == 0)
    assert (before.body == 0).sum() > 20 and (after.body == 0).sum() > 20
    assert not np.array_equal(before.body == 0, after.body == 0)
    # Rays that touch the ball in neither pose see exactly the same static world.
    for field in ("distance", "label", "normal", "reflectivity", "body"):
        np.testing.assert_array_equal(
            getattr(before, field)[~on_ball], getattr(after, field)[~on_ball]
        )
    # The ball's hits follow it: a ray at the new centre hits at |c - o| - r (≤ tessellation).
    h = rc.cast([[0.0, 0.0, 4.0]], [_unit([6.0, 3.0, 0.0])], 40.0)
    assert h.body[0] == 0
    assert math.hypot(6.0, 3.0) - 0.5 <= h.distance[0] <= math.hypot(6.0, 3.0) - 0.49


def test_set_pose_does_not_rebuild_static_bvh() -> None:
    scene = _separation_scene()
    rc = scene.raycaster("embree")
    static_bvh = rc._static
    o, d = _fan(8, 4)
    rc.cast(o, d, 40.0)
    body_bvhs = list(rc._parts["ball"].groups)
    for k in range(5):
        scene.set_pose("ball", (6.0, k, 4.0), rot_z(0.1 * k), kick_phase=0.2 * k)
        rc.cast(o, d, 40.0)
    assert rc._static is static_bvh
    assert all(a is b for a, b in zip(rc._parts["ball"].groups, body_bvhs, strict=True))
    scene.add_static(prim.box((1, 1, 1), (20.0, 0.0, 4.0)), "box", STEEL)  # rebuilt lazily
    h = rc.cast([[0.0, 0.0, 4.0]], [[1.0, 0.0, 0.0]], 40.0)
    assert rc._static is not static_bvh and scene.labels[h.label[0]] == "box"


@pytest.mark.parametrize("backend", BACKENDS)
def test_exclude_hides_a_body(backend: str) -> None:
    scene = _separation_scene()
    static_only = Scene()
    static_only.add_static(sf.flat(8.0, 40.0), "seafloor", SAND)
    for e in (-2.0, 2.0):
        static_only.add_static(prim.box((0.4, 0.4, 9.0), (12.0, e, 4.0)), "piling", CONCRETE)
    o, d = _fan()
    seen = scene.raycaster(backend).cast(o, d, 40.0)
    hidden = scene.raycaster(backend).cast(o, d, 40.0, exclude=frozenset({"ball", "no-such"}))
    ref = static_only.raycaster(backend).cast(o, d, 40.0)
    assert (seen.body == 0).sum() > 20 and not np.any(hidden.body == 0)
    np.testing.assert_array_equal(hidden.distance, ref.distance)
    np.testing.assert_array_equal(hidden.label, ref.label)


def test_labels_are_shared_and_bodies_indexed() -> None:
    scene = _separation_scene()
    assert scene.labels == ["seafloor", "piling", "diver"]
    assert scene.body_names == ["ball"]
    h = scene.raycaster().cast([[0.0, 2.0, 4.0], [0.0, -2.0, 4.0]], [[1, 0, 0], [1, 0, 0]], 40.0)
    assert list(h.label) == [1, 1]  # both pilings share the label "piling"
    np.testing.assert_allclose(h.distance, [11.8, 11.8])
    b = scene.bounds()
    np.testing.assert_allclose(b[0], [-40.0, -40.0, -0.5])
    np.testing.assert_allclose(b[1], [40.0, 40.0, 8.5])


def test_kick_phase_changes_diver_hits_only() -> None:
    scene = Scene()
    scene.add_dynamic("diver", diver_parts(), "diver", NEOPRENE, (0.0, 0.0, 4.0))
    rc = scene.raycaster()
    # Look at the fins from the side (east of the diver, looking west).
    n = np.linspace(-1.4, -0.6, 60)
    z = np.linspace(3.5, 4.5, 60)
    nn, zz = np.meshgrid(n, z)
    o = np.column_stack([nn.ravel(), np.full(nn.size, 3.0), zz.ravel()])
    d = np.tile([0.0, -1.0, 0.0], (len(o), 1))
    a = rc.cast(o, d, 10.0).hit
    scene.set_pose("diver", (0.0, 0.0, 4.0), np.eye(3), kick_phase=math.pi / 2)
    b = rc.cast(o, d, 10.0).hit
    assert a.sum() > 100 and b.sum() > 100
    assert (a != b).sum() > 50  # the fins' silhouette moved


def test_bad_inputs_raise_config_errors() -> None:
    scene = _separation_scene()
    rc = scene.raycaster()
    o, d = np.zeros((2, 3)), np.array([[1.0, 0, 0], [0, 1.0, 0]])
    for bad in (0.0, -1.0, float("nan"), "far"):
        with pytest.raises(ConfigError, match="max_range"):
            rc.cast(o, d, bad)
    with pytest.raises(ConfigError, match=r"directions.*unit"):
        rc.cast(o, np.array([[1.0, 0, 0], [0, 2.0, 0]]), 10.0)
    with pytest.raises(ConfigError, match="directions"):
        rc.cast(o, np.array([[1.0, 0, 0], [np.nan, 0, 0]]), 10.0)
    with pytest.raises(ConfigError, match="origins"):
        rc.cast(np.array([[0, 0, np.inf], [0, 0, 0]]), d, 10.0)
    with pytest.raises(ConfigError, match="shape"):
        rc.cast(np.zeros((2, 2)), d, 10.0)
    with pytest.raises(ConfigError, match="backend"):
        scene.raycaster("optix")
    with pytest.raises(ConfigError, match="no dynamic body named 'nobody'"):
        scene.set_pose("nobody", (0, 0, 0), np.eye(3))
    with pytest.raises(ConfigError, match="rotation"):
        scene.set_pose("ball", (0, 0, 0), 2.0 * np.eye(3))
    with pytest.raises(ConfigError, match="already exists"):
        scene.add_dynamic("ball", prim.sphere(1.0), "x", STEEL)
    with pytest.raises(ConfigError, match="reflectivity"):
        Material("unobtainium", 1.5)
    for e in (ConfigError,):
        try:
            rc.cast(o, d, 0.0)
        except e as exc:
            assert "\n" not in str(exc)
    assert len(rc.cast(np.zeros((0, 3)), np.zeros((0, 3)), 1.0).distance) == 0


def test_segment_clear_against_wall_and_free_space() -> None:
    scene = Scene()
    scene.add_static(prim.box((0.2, 10.0, 10.0), (10.1, 0.0, 4.0)), "wall", CONCRETE)  # x=10
    scene.add_dynamic("rov", prim.sphere(0.2), "rov", STEEL, (0.0, 0.0, 4.0))
    rov_excl = frozenset({"rov"})
    # A sphere of radius r heading straight at a wall x = 10 from x = 0 touches it after
    # 10 - r: fraction (10 - r) / L.
    for r, length in ((0.0, 20.0), (0.3, 20.0), (0.5, 12.0)):
        f = scene.segment_clear((0.0, 0.0, 4.0), (length, 0.0, 4.0), r, rov_excl)
        assert f == pytest.approx((10.0 - r) / length, abs=1e-9)
    assert scene.segment_clear((0, 0, 4), (5, 0, 4), 0.3, rov_excl) == 1.0
    assert scene.segment_clear((0, 0, 4), (0, 0, 4), 0.3, rov_excl) == 1.0
    # Its own body blocks it unless excluded: rays from inside the 0.2 m body hit its shell
    # about 0.1 m ahead, i.e. a fraction of about (0.2 - 0.1) / 5.
    assert scene.segment_clear((0, 0, 4), (5, 0, 4), 0.1) < 0.021
    # A thin pole 0.25 m off the path is caught by the sphere's ring of rays (r = 0.3).
    scene.add_static(prim.vertical_cylinder(0.03, 5.0, 0.25, 0.0, 8.0), "pole", STEEL)
    f = scene.segment_clear((0, 0, 4), (8, 0, 4), 0.3, rov_excl)
    assert 0.55 < f < 5.0 / 8.0
    with pytest.raises(ConfigError, match="radius"):
        scene.segment_clear((0, 0, 4), (1, 0, 4), -1.0)


def test_single_piling_scene_range_and_bearing() -> None:
    # The face turned to the sonar is at range - width/2 along the bearing.
    for range_m, bearing in ((10.0, 0.0), (7.5, 20.0), (15.0, -15.0)):
        ps = single_piling_scene(range_m, bearing, width=0.4)
        p = ps.sonar_poses["origin"]
        b = math.radians(bearing)
        h = ps.scene.raycaster().cast([p.position_ned], [[math.cos(b), math.sin(b), 0.0]], 50.0)
        assert ps.scene.labels[h.label[0]] == "piling"
        assert h.distance[0] == pytest.approx(range_m - 0.2, abs=1e-9)
    with pytest.raises(ConfigError, match="range_m"):
        single_piling_scene(0.1)


def test_pier_scene_beams_reach_floor_and_surface() -> None:
    ps = pier_scene(with_diver=True, with_rov=True)
    scene = ps.scene
    assert set(scene.labels) == {"seafloor", "piling", "rov", "diver"}
    assert scene.body_names == ["videoray", "diver"]
    assert sum(o.label == "piling" for o in scene.static_objects) == 10
    floor = scene.seafloor
    assert floor is not None
    # Looking north along a beam row (east = 3 m) just below the surface and just above
    # the floor, the first thing hit is the first beam (north = 8 m, front face 7.8 m).
    rc = scene.raycaster()
    h = rc.cast([[0.0, 3.0, 0.2]], [[1.0, 0.0, 0.0]], 50.0)
    assert scene.labels[h.label[0]] == "piling"
    assert h.distance[0] == pytest.approx(7.8, abs=1e-9)
    z_low = float(np.min(floor.depth_at(np.linspace(7.5, 7.8, 31), 3.0))) - 0.02
    h = rc.cast([[7.5, 3.0, z_low]], [[1.0, 0.0, 0.0]], 50.0)
    assert scene.labels[h.label[0]] == "piling"
    assert h.distance[0] == pytest.approx(0.3, abs=1e-9)
    depths = floor.depth
    assert depths.min() > 7.0 and depths.max() < 10.0  # realistic 5-10 m of water


@pytest.mark.parametrize("backend", BACKENDS)
def test_unchecked_set_pose_stores_copies_and_matches_checked(backend: str) -> None:
    checked, unchecked = _separation_scene(), _separation_scene()
    position, rotation = np.array([6.0, 3.0, 4.0]), rot_z(0.4)
    checked.set_pose("ball", position, rotation, kick_phase=0.3)
    unchecked.set_pose("ball", position, rotation, kick_phase=0.3, checked=False)
    position[:] = (1.0, 1.0, 1.0)  # the caller's arrays change afterwards: the body stays
    rotation[:] = 0.0
    o, d = _fan()
    a = checked.raycaster(backend).cast(o, d, 40.0)
    b = unchecked.raycaster(backend).cast(o, d, 40.0)
    assert (a.body == 0).sum() > 20
    for field in ("distance", "label", "normal", "reflectivity", "body"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_torus_scene_ring_and_hole() -> None:
    ps = torus_scene(water_depth=8.0, major_radius=1.5, minor_radius=0.3, distance=10.0)
    rc = ps.scene.raycaster()
    down = [[0.0, 0.0, 1.0]]
    h = rc.cast([[10.0 + 1.5, 0.0, 0.0]], down, 50.0)  # onto the ring's crest
    assert ps.scene.labels[h.label[0]] == "torus"
    assert 8.0 - 0.6 - 1e-9 <= h.distance[0] <= 8.0 - 0.6 + 0.3 * (1 - math.cos(math.pi / 16))
    h = rc.cast([[10.0, 0.0, 0.0]], down, 50.0)  # through the hole onto the floor
    assert ps.scene.labels[h.label[0]] == "seafloor"
    assert h.distance[0] == pytest.approx(8.0)


def test_scene_pickles_for_batch_runs() -> None:
    import pickle

    scene = _separation_scene()
    scene.segment_clear((0.0, 0.0, 4.0), (3.0, 0.0, 4.0), 0.3)  # caches an Embree caster
    scene.set_pose("ball", (6.0, 1.0, 4.0), rot_z(0.5))
    clone = pickle.loads(pickle.dumps(scene))
    o, d = _fan(16, 4)
    a = scene.raycaster().cast(o, d, 40.0)
    b = clone.raycaster().cast(o, d, 40.0)
    np.testing.assert_array_equal(a.distance, b.distance)
    np.testing.assert_array_equal(a.body, b.body)


def test_threaded_embree_matches_single_thread() -> None:
    ps = pier_scene(with_diver=True)
    o, d = _fan(128, 64, origin=(0.0, 0.0, 3.0))  # 8192 rays: split across 2 threads
    one = ps.scene.raycaster("embree").cast(o, d, 30.0)
    two = ps.scene.raycaster("embree", threads=2).cast(o, d, 30.0)
    for field in ("distance", "label", "normal", "reflectivity", "body"):
        np.testing.assert_array_equal(getattr(one, field), getattr(two, field))
    with pytest.raises(ConfigError, match="threads"):
        ps.scene.raycaster("embree", threads=0)


@pytest.mark.slow
@pytest.mark.parametrize("backend", BACKENDS)
def test_shared_origin_equals_one_origin_per_ray(backend: str) -> None:
    """A (3,) origin (a sensor's fan) is the same question as that origin on every row,
    static geometry and an articulated body alike, and must give identical answers."""
    scene = _separation_scene()
    add_diver(scene, "diver", (7.0, 2.0, 4.5), 1.57)  # broadside, in the fan
    rc = scene.raycaster(backend)
    o, d = _fan(48, 24)
    rows = rc.cast(o, d, 30.0)
    shared = rc.cast(o[0], d, 30.0)
    diver = scene.body_names.index("diver")
    assert (rows.body == diver).sum() > 5 and (rows.label == -1).any() and (rows.body == 0).any()
    for field in ("distance", "label", "normal", "reflectivity", "body"):
        np.testing.assert_array_equal(getattr(rows, field), getattr(shared, field))
    with pytest.raises(ConfigError, match=r"origins.*\(3,\)"):
        rc.cast(np.zeros(2), d, 30.0)


def test_hit_points_and_depth_queries() -> None:
    scene = Scene()
    assert math.isnan(scene.depth_at(0.0, 0.0))  # no sea floor yet
    scene.add_static(sf.sloped(6.0, 0.1, 0.0, 20.0), "seafloor", SAND)
    o = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    d = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    h = scene.raycaster().cast(o, d, 20.0)
    p = h.points(o, d)
    np.testing.assert_allclose(p[0], [0.0, 0.0, 6.0])  # straight down onto 6 m
    assert np.all(np.isnan(p[1]))  # straight up: nothing
    np.testing.assert_allclose(scene.depth_at([0.0, 10.0], [3.0, 3.0]), [6.0, 7.0])
