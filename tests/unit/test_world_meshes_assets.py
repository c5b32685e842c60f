"""Mesh loading errors, primitive sizes, the VideoRay and diver assets."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from uhrisim.core.errors import AssetError, ConfigError
from uhrisim.world import primitives as prim
from uhrisim.world.assets import diver_mesh, diver_parts, videoray_mesh
from uhrisim.world.kick import DIVER_HIP_AMPLITUDE_RAD, diver_kick_phase_rate
from uhrisim.world.materials import ALUMINIUM, DEFAULT_MATERIALS, NEOPRENE
from uhrisim.world.meshes import load_mesh


@pytest.mark.parametrize("suffix", ["obj", "stl", "ply", "glb"])
def test_load_mesh_pose_and_scale(tmp_path, suffix: str) -> None:
    path = tmp_path / f"box.{suffix}"
    trimesh.creation.box((1.0, 2.0, 3.0)).export(path)
    m = load_mesh(path, scale=2.0, position_ned=(10.0, 0.0, 5.0), yaw=math.pi / 2)
    # Scaled to 2 x 4 x 6, yawed 90° (its 4 m y-extent now lies north-south), moved to
    # (10, 0, 5): north 10 ± 2, east ± 1, depth 5 ± 3.
    np.testing.assert_allclose(m.bounds, [[8.0, -1.0, 2.0], [12.0, 1.0, 8.0]], atol=1e-9)


def test_load_glb_scene_is_flattened(tmp_path) -> None:
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box((1, 1, 1)))
    scene.add_geometry(
        trimesh.creation.box((1, 1, 1)),
        transform=trimesh.transformations.translation_matrix([5, 0, 0]),
    )
    scene.export(tmp_path / "two.glb")
    m = load_mesh(tmp_path / "two.glb")
    assert len(m.faces) == 24
    np.testing.assert_allclose(m.bounds, [[-0.5, -0.5, -0.5], [5.5, 0.5, 0.5]], atol=1e-6)


@pytest.mark.parametrize("suffix", ["stl", "glb", "obj", "ply"])
def test_corrupt_file_is_a_one_line_asset_error(tmp_path, suffix: str) -> None:
    path = tmp_path / f"corrupt.{suffix}"
    path.write_bytes(bytes(np.random.default_rng(3).integers(0, 256, 300, dtype=np.uint8)))
    with pytest.raises(AssetError) as exc:
        load_mesh(path)
    msg = str(exc.value)
    assert msg.startswith(str(path)) and "\n" not in msg


def test_missing_empty_and_unsupported_files(tmp_path) -> None:
    with pytest.raises(AssetError, match=r"nope\.stl: mesh file not found"):
        load_mesh(tmp_path / "nope.stl")
    empty = tmp_path / "empty.obj"
    empty.write_text("# no faces\nv 0 0 0\n")
    with pytest.raises(AssetError, match=r"empty\.obj: file holds no triangles"):
        load_mesh(empty)
    odd = tmp_path / "model.xyz"
    odd.write_text("1 2 3\n")
    with pytest.raises(AssetError, match="unsupported mesh format"):
        load_mesh(odd)
    with pytest.raises(ConfigError, match="scale"):
        load_mesh(empty, scale=0.0)


def test_primitive_dimensions_and_validation() -> None:
    # A cylinder standing on an 8 m floor up to the surface spans z 0..8 (NED z down).
    c = prim.vertical_cylinder(0.2, 3.0, 4.0, z_top=0.0, z_bottom=8.0)
    np.testing.assert_allclose(c.bounds, [[2.8, 3.8, 0.0], [3.2, 4.2, 8.0]], atol=1e-12)
    cap = prim.capsule(0.3, 1.0)
    np.testing.assert_allclose(cap.bounds[:, 2], [-0.8, 0.8], atol=1e-9)  # height + 2 r
    tor = prim.torus(2.0, 0.5)
    np.testing.assert_allclose(tor.extents, [5.0, 5.0, 1.0], atol=1e-2)
    box = prim.box((1.0, 2.0, 3.0), rotation=[[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    np.testing.assert_allclose(box.extents, [2.0, 1.0, 3.0], atol=1e-12)
    for m in (c, cap, tor, box, prim.sphere(1.0)):
        assert m.is_watertight and m.volume > 0
    with pytest.raises(ConfigError, match=r"box\.size\[1\]"):
        prim.box((1.0, 0.0, 1.0))
    with pytest.raises(ConfigError, match="minor_radius"):
        prim.torus(1.0, 1.5)
    with pytest.raises(ConfigError, match="rotation"):
        prim.box((1, 1, 1), rotation=np.diag([1.0, 1.0, -1.0]))


def test_default_materials_are_ordered_sensibly() -> None:
    m = DEFAULT_MATERIALS
    assert m["sand"].reflectivity < m["concrete"].reflectivity < m["steel"].reflectivity
    assert 0.01 <= m["sand"].reflectivity <= 0.03
    assert all(0.0 <= v.reflectivity <= 1.0 for v in m.values())


def test_videoray_matches_datasheet_envelope() -> None:
    m = videoray_mesh()
    # VideoRay Pro 4: 37.5 cm long, 28.9 cm wide, 22.3 cm high; origin at the centre.
    np.testing.assert_allclose(m.extents, [0.375, 0.289, 0.223], atol=1e-3)
    np.testing.assert_allclose(m.bounds.mean(axis=0), 0.0, atol=1e-3)
    assert len(m.faces) < 2000


def test_diver_size_orientation_and_materials() -> None:
    parts = diver_parts(NEOPRENE, ALUMINIUM)
    names = [p.name for p in parts.parts]
    assert names == ["core", "tank", "left_leg", "left_fin", "right_leg", "right_fin"]
    assert parts.n_faces < 5000
    m = diver_mesh(0.0)
    length = m.extents[0]
    assert 2.2 <= length <= 2.4  # ~1.8 m person + fins
    no_fins = parts.parts[0].mesh.bounds[1, 0] - parts.parts[2].mesh.bounds[0, 0]
    assert 1.6 <= no_fins <= 1.9
    head_x = parts.parts[0].mesh.bounds[1, 0]
    assert head_x > 0.9 and m.bounds[0, 0] < -1.1  # head forward (+x), fins aft
    tank = parts.parts[1].mesh
    assert tank.bounds[1, 2] < 0.0  # tank on the back: up, i.e. -z in FRD
    refl = parts.face_reflectivity(NEOPRENE)
    n_core = len(parts.parts[0].mesh.faces)
    assert np.all(refl[n_core : n_core + len(tank.faces)] == ALUMINIUM.reflectivity)


def test_diver_flutter_kick_is_opposite_phase_about_the_hips() -> None:
    parts = diver_parts()
    left, right = parts.parts[2], parts.parts[4]
    hip_x = 0.22
    rest_centroid = left.mesh.vertices.mean(axis=0)
    lever = rest_centroid[0] - hip_x  # negative: the leg trails the hip
    for phase in (math.pi / 2, 1.0, 4.0):
        tl, tr = left.transform(phase), right.transform(phase)
        zl = (tl[:3, :3] @ rest_centroid + tl[:3, 3])[2]
        zr = (tr[:3, :3] @ right.mesh.vertices.mean(axis=0) + tr[:3, 3])[2]
        # Rotation by a = A sin(phase) about +y through the hip moves the centroid to
        # z = -lever * sin(a); the right leg has the opposite angle.
        a = DIVER_HIP_AMPLITUDE_RAD * math.sin(phase)
        assert zl == pytest.approx(-lever * math.sin(a), abs=1e-12)
        assert zr == pytest.approx(-zl, abs=1e-12)
    # The silhouette changes with phase: the left fin's depth extent differs.
    fin_z = [
        np.ptp(parts.triangles_at(ph)[parts.face_offsets[3] : parts.face_offsets[4], :, 2])
        for ph in (0.0, math.pi / 2)
    ]
    assert abs(fin_z[0] - fin_z[1]) > 0.05
    assert not np.allclose(diver_mesh(0.0).vertices, diver_mesh(2.0).vertices)


def test_kick_rate_rises_with_speed() -> None:
    # f = speed / 0.6 m per cycle, capped at 1.5 Hz; returned as rad/s.
    assert diver_kick_phase_rate(0.0) == 0.0
    assert diver_kick_phase_rate(0.3) == pytest.approx(2 * math.pi * 0.5)
    assert diver_kick_phase_rate(0.6) == pytest.approx(2 * math.pi * 1.0)
    assert diver_kick_phase_rate(-0.3) == diver_kick_phase_rate(0.3)
    assert diver_kick_phase_rate(5.0) == pytest.approx(2 * math.pi * 1.5)
    with pytest.raises(ConfigError):
        diver_kick_phase_rate(float("nan"))


def test_joint_transform_is_a_rotation_about_its_pivot() -> None:
    from uhrisim.world.bodies import Joint

    j = Joint((0.2, -0.1, 0.3), (0.3, 1.0, -0.2), amplitude_rad=0.4, phase_offset_rad=0.7)
    axis = np.asarray(j.axis)
    for phase in (0.0, 1.3, 4.0):
        m = j.transform(phase)
        rot = m[:3, :3]
        np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-14)
        np.testing.assert_allclose(m[:3, :3] @ j.pivot + m[:3, 3], j.pivot, atol=1e-14)
        np.testing.assert_allclose(rot @ axis, axis, atol=1e-14)  # the axis stays put
        # The rotation angle: trace(R) = 1 + 2 cos(a), a = A sin(phase + offset).
        a = 0.4 * math.sin(phase + 0.7)
        assert np.trace(rot) == pytest.approx(1.0 + 2.0 * math.cos(a), abs=1e-14)


def test_part_transforms_are_each_parts_own_product_bit_for_bit() -> None:
    """ArticulatedMesh.part_transforms poses each joint and chain prefix once: the same
    products as every Part.transform, to the bit, and one array per distinct chain."""
    from uhrisim.world.bodies import ArticulatedMesh, Joint, Part

    diver = diver_parts()
    hip, knee = diver.parts[5].chain  # right_fin: hip, ankle
    twin_hip = Joint(hip.pivot, hip.axis, hip.amplitude_rad, hip.phase_offset_rad)  # == hip
    toe = Joint((0.1, 0.0, -0.3), (0.2, -1.0, 0.0), 0.3, 0.4, bias_rad=-0.1)
    box = prim.box((0.1, 0.1, 0.1), (0.0, 0.0, 0.0))
    odd = ArticulatedMesh((Part("shin", box, (knee,)), Part("leg", box, (twin_hip, knee)),
                           Part("toe", box, (hip, knee, toe)), Part("core", box),
                           Part("foot", box, (hip, knee))))
    for mesh in (diver, odd):
        for phase in np.linspace(-7.0, 40.0, 97):
            posed = mesh.part_transforms(float(phase))
            for part, transform in zip(mesh.parts, posed, strict=True):
                assert transform.tobytes() == part.transform(float(phase)).tobytes()
    posed = odd.part_transforms(1.0)
    assert posed[1] is posed[4] and posed[0] is not posed[1]
