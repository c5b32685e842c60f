"""The articulated diver's meshes: posed from joint angles, each part labelled in ray hits."""

import math

import numpy as np
import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.dynamics import diver_body as db
from uhrisim.world import Scene, materials
from uhrisim.world import primitives as prim
from uhrisim.world.diver_figure import diver_figure, figure_transforms, posed_figure
from uhrisim.world.kick import flutter_kick

SCUBA = db.DiverSkeleton()
BOOTS = db.DiverSkeleton(kind="boots")
DEPTH = 6.0


def scene_with(skeleton, q, backend):
    scene = Scene()
    scene.add_dynamic("diver1", diver_figure(skeleton), "diver", materials.NEOPRENE,
                      position_ned=(0.0, 0.0, DEPTH))
    scene.set_part_transforms("diver1", figure_transforms(skeleton, q))
    return scene, scene.raycaster(backend)


def test_parts_follow_the_links_and_carry_the_issue_labels():
    scuba = diver_figure(SCUBA)
    assert [p.name for p in scuba.parts] == list(SCUBA.links)
    assert set(scuba.part_labels("diver")) == {
        "diver", "diver/head", "diver/tank", "diver/arm", "diver/hand", "diver/fins"}
    boots = diver_figure(BOOTS)
    assert set(boots.part_labels("diver")) == {
        "diver", "diver/head", "diver/tank", "diver/arm", "diver/hand", "diver/boots"}
    # the zero configuration is the rest pose: every transform is the identity
    np.testing.assert_allclose(figure_transforms(SCUBA, SCUBA.zeros()),
                               np.broadcast_to(np.eye(4), (len(scuba.parts), 4, 4)))


def test_standing_commercial_diver_is_as_tall_as_the_stature_with_a_helmet():
    bounds = posed_figure(BOOTS, BOOTS.zeros()).bounds
    assert bounds[1][2] == pytest.approx(BOOTS.body.hip_height)  # soles on z = hip height
    height = bounds[1][2] - bounds[0][2]
    assert db.STATURE_M < height < db.STATURE_M + 0.08  # the helmet's top above the scalp


def test_swimming_diver_is_prone_and_about_2_3_m_long_with_fins():
    bounds = posed_figure(SCUBA, db.pose_goal(SCUBA, "swim")).bounds
    length = bounds[1][0] - bounds[0][0]
    assert 2.1 < length < 2.5  # the procedural swimmer of world.assets: ~2.3 m with fins
    assert bounds[1][2] - bounds[0][2] < 0.75  # flat: no more than 0.75 m top to bottom


@pytest.mark.parametrize("backend", ["embree", "reference"])
def test_ray_hits_name_the_posed_part(backend):
    """A ray straight down onto the grip point of the reaching right hand hits a part
    labelled diver/hand; one onto the tank, diver/tank; the torso is plain diver. Both ray
    casters agree, and they see the pose set by set_part_transforms."""
    q = db.pose_goal(SCUBA, "reach", SCUBA.zeros())
    scene, caster = scene_with(SCUBA, q, backend)
    offset = np.array([0.0, 0.0, DEPTH])
    grip = SCUBA.grip_point(q, "right") + offset
    tank = np.array([-0.3, 0.0, -0.25]) + offset
    torso = np.array([0.0, 0.0, -0.25]) + offset
    origins = np.array([grip, tank, torso]) + np.array([[0, 0, -1.0], [-1.0, 0, 0], [1.0, 0, 0]])
    directions = np.array([[0, 0, 1.0], [1.0, 0, 0], [-1.0, 0, 0]])
    hits = caster.cast(origins, directions, max_range=3.0)
    assert [scene.labels[i] for i in hits.label] == ["diver/hand", "diver/tank", "diver"]
    # the flat hand (3 cm thick about the grip point) faces down: the ray stops 1.5 cm short
    assert hits.distance[0] == pytest.approx(1.0 - 0.5 * 0.03, abs=0.005)


def test_embree_and_reference_agree_on_a_fan_over_a_posed_diver():
    q = db.pose_goal(SCUBA, "work", db.pose_goal(SCUBA, "swim"))
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(400, 3)) * [0.3, 0.3, 1.0] + [0.0, 0.0, 1.0]
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    origin = np.array([0.0, 0.0, DEPTH - 2.0])
    out = []
    for backend in ("embree", "reference"):
        scene, caster = scene_with(SCUBA, q, backend)
        hits = caster.cast(origin, directions, max_range=5.0)
        out.append((hits.distance, [scene.labels[i] if i >= 0 else "" for i in hits.label]))
    np.testing.assert_allclose(out[0][0], out[1][0], rtol=1e-9)
    assert out[0][1] == out[1][1]
    assert {"diver", "diver/arm", "diver/hand"} <= set(out[0][1])


def test_set_part_transforms_checks_its_input():
    scene, _ = scene_with(SCUBA, SCUBA.zeros(), "reference")
    with pytest.raises(ConfigError, match="must be 20 finite 4x4 matrices"):
        scene.set_part_transforms("diver1", np.eye(4)[None])
    with pytest.raises(ConfigError, match="no dynamic body named 'rov'"):
        scene.set_part_transforms("rov", np.eye(4)[None])


def test_flutter_kick_swings_the_legs_in_opposite_phase_within_the_limits():
    swim = db.pose_goal(SCUBA, "swim")
    for phase in np.linspace(0.0, 2.0 * math.pi, 17):
        q = flutter_kick(SCUBA, swim, phase)
        assert SCUBA.limit_violations(q) == []
        left, right = q[SCUBA.index("left_hip_flex")], q[SCUBA.index("right_hip_flex")]
        assert left == pytest.approx(-right, abs=1e-12)


def working_diver_and_fan(rng, n_rays):
    """A scuba diver at work, its Embree scene and caster, and a fan of ``n_rays`` unit
    directions from 2 m above him (its origin), looking down at him."""
    q = db.pose_goal(SCUBA, "work", db.pose_goal(SCUBA, "swim"))
    scene, caster = scene_with(SCUBA, q, "embree")
    d = rng.normal(size=(n_rays, 3)) * [0.3, 0.3, 1.0] + [0.0, 0.0, 1.0]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return scene, caster, d, np.array([0.0, 0.0, DEPTH - 2.0])


@pytest.mark.parametrize("shared_origin", [True, False])
def test_compiled_group_selection_keeps_every_ray_that_meets_the_group(shared_origin):
    """The Embree caster picks each rigid group's rays (bounding sphere, then rest-frame
    box) in one compiled pass: every ray that hits the group within its bound must be
    picked (conservative), no more than the numpy tests pick, and the plain function
    gives what numba compiles."""
    from uhrisim.world import raycast

    rng = np.random.default_rng(5)
    scene, caster, d, origin = working_diver_and_fan(rng, 1000)
    o = origin if shared_origin else origin + rng.normal(scale=0.2, size=d.shape)
    bound = rng.uniform(1.0, 4.0, len(d))
    body = scene.bodies[0]
    bvh = caster._parts[body.name]
    frames = np.array([body.pose_matrix() @ body.part_transforms[i] for i in bvh.group_part])
    rots, trans = frames[:, :3, :3], frames[:, :3, 3]
    centres = np.einsum("gij,gj->gi", rots, bvh.centres) + trans
    args = (o.reshape(-1, 3), d, bound, centres, bvh.radii, rots, trans, bvh.box_lo,
            bvh.box_hi, np.ones(len(bvh.groups), bool))
    n, groups = len(d), len(bvh.groups)
    picked = []
    for select in (raycast._group_rays, raycast._compiled_group_rays()):
        if select is None:  # numba not installed: the numpy tests run instead
            continue
        chosen, counts = np.empty(groups * n, np.int64), np.zeros(groups, np.int64)
        select(*args, chosen, counts)
        picked.append([chosen[g * n : g * n + counts[g]].copy() for g in range(groups)])
    cull = raycast._RayCuller(o, d)
    hitting = 0
    for g, mesh in enumerate(bvh.groups):
        o_local = (o - trans[g]) @ rots[g]
        face, _, _ = mesh.intersect(o_local, d @ rots[g], bound)
        hit_rows = np.flatnonzero(face >= 0)
        hitting += len(hit_rows)
        numpy_rows = bvh._numpy_group_rays(mesh, cull, o, d, bound, centres[g], rots[g],
                                           trans[g])
        assert np.isin(hit_rows, numpy_rows).all()
        for rows in picked:
            assert np.all(np.diff(rows[g]) > 0)
            assert np.isin(hit_rows, rows[g]).all()
            assert len(rows[g]) <= len(numpy_rows)
            assert np.array_equal(rows[g], picked[0][g])
    assert hitting > 100  # the fan does meet the diver


def test_compiled_and_numpy_casts_give_the_same_bits(monkeypatch):
    """With numba the Embree caster culls, picks each group's rays, forms Embree's float32
    rows, refines Embree's hits and keeps a group's and a body's hits in compiled passes;
    without it, numpy does: every field of every hit is the same to the bit (shared and
    per-ray origins, with hits past the range made misses)."""
    from uhrisim.world import raycast

    rng = np.random.default_rng(7)
    _, caster, d, origin = working_diver_and_fan(rng, 1500)
    shots = [(origin, 2.3), (origin + rng.normal(scale=0.2, size=d.shape), 5.0)]
    compiled = [caster.cast(o, d, max_range=r) for o, r in shots]
    for name in ("_compiled_spheres_rays", "_compiled_box_rays", "_compiled_group_rays",
                 "_compiled_refine_rows", "_compiled_embree_rays", "_compiled_group_hits",
                 "_compiled_nearer_hits"):
        monkeypatch.setattr(raycast, name, lambda: None)
    for (o, r), fast in zip(shots, compiled, strict=True):
        slow = caster.cast(o, d, max_range=r)
        assert np.isfinite(slow.distance).sum() > 200
        for field in ("distance", "label", "normal", "reflectivity", "body", "material"):
            assert getattr(fast, field).tobytes() == getattr(slow, field).tobytes(), field


@pytest.mark.parametrize("shared_origin", [True, False])
def test_one_pass_over_all_bodies_spheres_keeps_each_spheres_rays(shared_origin):
    """The caster culls the rays against every body's bounding sphere in one compiled
    pass: per sphere, the very rays (and order) of :class:`_RayCuller`'s test."""
    from uhrisim.world.raycast import _compiled_spheres_rays, _RayCuller, _rays_near_spheres

    if _compiled_spheres_rays() is None:
        pytest.skip("numba is off")
    rng = np.random.default_rng(11)
    d = rng.normal(size=(3000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    above = np.array([0.0, 0.0, 3.0])
    o = np.array([0.5, -0.2, 3.0]) if shared_origin else above + rng.normal(size=(3000, 3))
    limit = rng.uniform(0.5, 6.0, 3000)
    centres = [above + rng.uniform(-2.0, 2.0, 3) for _ in range(5)]
    radii = [float(r) for r in rng.uniform(0.2, 1.5, 5)]
    cull = _RayCuller(o, d)
    picked = _rays_near_spheres(o, d, limit, centres, radii)
    for rows, c, r in zip(picked, centres, radii, strict=True):
        assert np.array_equal(rows, cull.candidates(limit, c, r))
    assert sum(len(rows) for rows in picked) > 100


@pytest.mark.parametrize("shared_origin", [True, False])
def test_compiled_static_box_pick_keeps_the_numpy_rays(shared_origin):
    """The static geometry's box test of a cast, compiled: the very rays of
    :meth:`_EmbreeMesh.box_candidates`, with rays along the axes (zero components, NaN
    slab times) and origins on the box's faces and inside its slabs."""
    from uhrisim.world.raycast import _compiled_box_rays, _EmbreeMesh, _rays_near_box

    if _compiled_box_rays() is None:
        pytest.skip("numba is off")
    rng = np.random.default_rng(12)
    box = Scene()
    box.add_static(prim.box((4.0, 2.0, 1.0), (1.0, 0.0, 5.0)), "box", materials.CONCRETE)
    mesh = box.raycaster()._static
    assert isinstance(mesh, _EmbreeMesh)
    d = rng.normal(size=(4000, 3))
    d[::7, rng.integers(0, 3)] = 0.0
    d[::11, :2] = 0.0
    d /= np.linalg.norm(d, axis=1)[:, None]
    if shared_origin:
        origins = [np.array([0.5, -0.2, 3.0]), np.array([0.0, 0.0, 5.0]), mesh.box_lo.copy()]
    else:
        o = rng.uniform(-3.0, 5.0, (4000, 3))
        o[::5, 0] = mesh.box_hi[0]
        origins = [o]
    counts = []
    for o in origins:
        for max_range in (2.0, np.inf):
            expected = mesh.box_candidates(o, d.T, np.full(len(d), max_range))
            assert np.array_equal(_rays_near_box(mesh, o, d, max_range), expected)
            counts.append(len(expected))
    assert min(counts) < len(d) and max(counts) > 100
