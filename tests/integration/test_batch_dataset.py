"""A 20-frame labelled sonar dataset on a real local Ray (one per module, 2 CPUs): the
same seed gives byte-identical files whatever the sharding and the number of workers,
another seed other frames; pycocotools reads the COCO file and each annotation's mask is
exactly its instance in the label image; the per-frame JSON counts the label images'
pixels; the dataset card counts what the COCO file holds.

The scene list includes a real mesh file (an OBJ written here by trimesh, loaded by
uhrisim's mesh loader) besides primitives and the built-in diver.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("ray")
coco_api = pytest.importorskip("pycocotools.coco")

import cv2  # noqa: E402
import trimesh  # noqa: E402

from uhrisim.batch.cluster import start_local_ray  # noqa: E402
from uhrisim.batch.dataset import run_dataset  # noqa: E402

FRAMES = 20
# pycocotools 2.0.x decodes masks with numpy's old __array__ protocol (its own warning)
pytestmark = pytest.mark.filterwarnings(
    "ignore:__array__ implementation doesn't accept a copy keyword:DeprecationWarning")


@pytest.fixture(scope="module")
def local_ray():
    import ray

    start_local_ray(2)
    yield ray
    ray.shutdown()


def dataset_file(folder: Path, seed: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    # a 0.6 m cone, written and read back as a file like a user's mesh
    trimesh.creation.cone(0.3, 0.6, sections=16).export(folder / "cone.obj")
    spec = {
        "name": "test-set", "frames": FRAMES, "seed": seed,
        "objects": {"count": [1, 3], "kinds": [
            {"type": "diver", "altitude": [0.3, 1.0]},
            {"type": "cylinder", "class": "piling", "radius": [0.2, 0.4], "height": [1, 3]},
            {"type": "box", "class": "crate", "size": [[0.5, 1.2], [0.5, 1.2], [0.3, 0.8]],
             "material": ["wood", "steel"]},
            {"type": "mesh", "class": "cone", "file": "cone.obj", "scale": [1.0, 2.0],
             "material": ["steel"]},
        ]},
        "sonar": {"preset": ["P900-45", "P900-90"], "range_max_m": [8, 12],
                  "settings": {"rays_per_beam": 8, "fan_size_px": 128,
                               "range_resolution_m": 0.1, "gain_db": {"uniform": [0, 6]}}},
    }
    path = folder / "dataset.yaml"
    path.write_text(json.dumps(spec))
    return path


def tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


@pytest.fixture(scope="module")
def first(local_ray, tmp_path_factory):
    folder = tmp_path_factory.mktemp("a")
    run_dataset(dataset_file(folder, seed=5), folder / "out", workers=2, shard_frames=3)
    return folder / "out"


def test_the_same_seed_gives_byte_identical_files(local_ray, first, tmp_path):
    again = tmp_path / "b"
    run_dataset(dataset_file(again, seed=5), again / "out", workers=1, shard_frames=20)
    a, b = tree(first), tree(again / "out")
    assert sorted(a) == sorted(b)
    assert len([n for n in a if n.startswith("fan/")]) == FRAMES
    assert [n for n in a if a[n] != b[n]] == []
    other = tmp_path / "c"
    run_dataset(dataset_file(other, seed=6), other / "out", workers=2, shard_frames=10)
    c = tree(other / "out")
    assert sum(a[n] != c[n] for n in a if n.startswith("fan/")) == FRAMES


def test_coco_masks_are_the_label_images(first):
    coco = coco_api.COCO(str(first / "annotations_coco.json"))
    assert [c["name"] for c in coco.loadCats(coco.getCatIds())] == [
        "diver", "piling", "crate", "cone"]
    assert len(coco.getImgIds()) == FRAMES
    checked = 0
    for image in coco.loadImgs(coco.getImgIds()):
        frame = json.loads((first / "frames" / f"{image['id'] - 1:06d}.json").read_text())
        labels = cv2.imread(str(first / frame["files"]["labels_fan"]), cv2.IMREAD_UNCHANGED)
        fan = cv2.imread(str(first / image["file_name"]), cv2.IMREAD_GRAYSCALE)
        assert labels.dtype == np.uint16 and labels.shape == fan.shape == (
            image["height"], image["width"])
        counts = np.bincount(labels.ravel(), minlength=len(frame["instances"]) + 1)
        assert counts[len(frame["instances"]) + 1:].sum() == 0  # no id beyond the list
        by_instance = {a["instance_id"]: a for a in coco.loadAnns(
            coco.getAnnIds(imgIds=image["id"]))}
        for instance in frame["instances"]:
            assert instance["pixels_fan"] == counts[instance["id"]]
            if instance["class"] == "seafloor" or not instance["pixels_fan"]:
                assert instance["id"] not in by_instance
                continue
            ann = by_instance[instance["id"]]
            mask = coco.annToMask(ann)
            np.testing.assert_array_equal(mask, labels == instance["id"])
            assert ann["area"] == instance["pixels_fan"]
            rows, cols = np.nonzero(mask)
            assert ann["bbox"] == [cols.min(), rows.min(), cols.max() - cols.min() + 1,
                                   rows.max() - rows.min() + 1]
            assert coco.cats[ann["category_id"]]["name"] == instance["class"]
            checked += 1
        polar = cv2.imread(str(first / frame["files"]["labels_polar"]), cv2.IMREAD_UNCHANGED)
        assert list(polar.shape) == frame["polar_shape"]
        assert frame["instances"][0]["pixels_polar"] == np.count_nonzero(polar == 1)
    assert checked >= FRAMES  # about two visible objects a frame
    card = (first / "README.md").read_text()
    assert f"frames: {FRAMES} (seed 5)" in card
    assert f"annotated instances (COCO, fan images): {len(coco.getAnnIds())}" in card
    for cat in coco.loadCats(coco.getCatIds()):
        shown = len(coco.getAnnIds(catIds=[cat["id"]]))
        assert f"| {cat['id']} | {cat['name']} | " in card and f" | {shown} |" in card
    preview = cv2.imread(str(first / "preview.png"))
    assert preview.shape == (4 * 192 + 26, 4 * 192, 3)  # 16 tiles, one legend row
    legend = preview[4 * 192:]
    from uhrisim.batch.dataset import category_colour

    for cat in coco.loadCats(coco.getCatIds()):  # each class has its swatch in the legend
        assert (legend == category_colour(cat["id"])).all(axis=2).sum() >= 100, cat


def test_frames_renders_the_first_frames_of_the_same_dataset(local_ray, first, tmp_path):
    """--frames 4: the first four frames of the 20-frame dataset, byte for byte."""
    few = tmp_path / "few"
    result = run_dataset(dataset_file(few, seed=5), few / "out", workers=2, shard_frames=3,
                         frames=4)
    assert result.frames == 4
    fans = tree(few / "out")
    whole = tree(first)
    names = [n for n in fans if n.startswith("fan/")]
    assert len(names) == 4 and all(fans[n] == whole[n] for n in names)
