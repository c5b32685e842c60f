"""Same scenario + seed ⇒ the same image bits, wherever the heap puts the arrays.

OpenCV's magnitude (Intel IPP's in the wheels) rounds the cells it peels off at a
buffer's head and tail (and beside zeros, or what lies past the buffer's ends) otherwise
than its vector body, so the coherent image and the speckle bank both models read could
differ by an ulp in a cell from run to run, with the heap's state (``polar.magnitude``).
These tests place the stages' operands at every float offset within a cache line with
zeros or ones around them, every array the stages allocate at each of malloc's offsets,
and draw banks and pings with the heap shifted between them; they demand the same bytes.
"""

from __future__ import annotations

import itertools
import types

import numpy as np
import pytest

from tests.support.analytic_sonar import LEVEL, ORIGIN, AnalyticCaster
from uhrisim.sensors.sonar import ImagingSonar, SonarConfig, polar, sonar, speckle
from uhrisim.sensors.sonar.speckle import SpeckleBank

#: Byte offsets from a 64-byte boundary that malloc's 16-byte aligned blocks take.
OFFSETS = (0, 16, 32, 48)


def placed(a: np.ndarray, offset: int, surround: float = 0.0) -> np.ndarray:
    """A copy of ``a`` whose data starts ``offset`` bytes past a 64-byte boundary, with
    ``surround`` in the memory around it (what lies there in a heap is whatever was)."""
    buf = np.full(a.nbytes + 128, surround, a.dtype if a.dtype.itemsize == 4 else np.float64)
    raw = buf.view(np.uint8)
    start = (-raw.ctypes.data) % 64 + offset
    out = raw[start : start + a.nbytes].view(a.dtype).reshape(a.shape)
    out[...] = a
    return out


def numpy_allocating_at(shift: int) -> types.SimpleNamespace:
    """The numpy module as a stage module sees it, but whose ``empty`` places the k-th
    array's data ``OFFSETS[(k + shift) % 4]`` bytes past a 64-byte boundary (so that
    arrays used together lie at varying offsets from each other too; every other name
    is numpy's)."""
    proxy = types.SimpleNamespace(**{k: getattr(np, k) for k in dir(np) if not k.startswith("__")})
    count = itertools.count(shift)
    proxy.empty = lambda shape, dtype=float: placed(np.empty(shape, dtype),
                                                    OFFSETS[next(count) % len(OFFSETS)])
    return proxy


def test_coherent_log_intensity_does_not_depend_on_where_its_operands_lie() -> None:
    rng = np.random.default_rng(3)
    shape = (242, 256)  # a block of rows of a P900-45 image
    c_re, c_im = (rng.standard_normal(shape, dtype=np.float32) for _ in range(2))
    results = set()
    for a, surround in itertools.product(range(0, 64, 4), (0.0, 1.0)):
        # every float's offset, each operand its own, zeros or not around them
        out = placed(np.zeros(shape, np.float32), (a + 20) % 64, surround)
        polar.coherent_log_intensity(placed(c_re, a, surround),
                                     placed(c_im, (3 * a) % 64, surround), out)  # fmt: skip
        results.add(out.tobytes())
    assert len(results) == 1


def test_the_speckle_bank_is_the_same_whatever_the_heap_holds() -> None:
    # The P900-130 at 30 m: on main its bank came out one of two ways, by the heap's state
    # (OpenCV's magnitude at the field's head cells), within a process and run to run.
    cfg = SonarConfig(preset="P900-130", range_max_m=30.0, rays_per_beam=4)
    sonar_ = ImagingSonar(cfg, np.random.default_rng(0))
    g = sonar_.geometry
    banks, held = set(), []
    for k in range(6):
        held.append(np.ones(4 * k + 1, np.float32))  # shifts what the next blocks follow
        bank = SpeckleBank.draw(np.random.default_rng(1), sonar_.polar_shape, g.beam_blocks,
                                g.range_amp, g.k_ln, scatterers=False)  # fmt: skip
        banks.add(bank.k_ln_w2.tobytes())
    assert len(banks) == 1


@pytest.mark.parametrize("model", ["product", "coherent"])
def test_same_pings_wherever_the_stages_arrays_lie(model: str, monkeypatch) -> None:
    """A P900-45 (steered beams: several pattern blocks) over a floor and a plate, three
    pings each, every ``np.empty`` of the sonar, its image stages and its speckle bank
    placed at malloc's offsets in four different ways."""
    cfg = SonarConfig(preset="P900-45", range_max_m=20.0, rays_per_beam=8, tilt_deg=15.0,
                      mount_position_frd=(0.0, 0.0, 0.0), speckle_model=model)  # fmt: skip
    caster = AnalyticCaster(plate_north=10.0, plate_half=0.5, plate_z=5.5)
    images = set()
    for shift in range(len(OFFSETS)):
        for module in (sonar, polar, speckle):
            monkeypatch.setattr(module, "np", numpy_allocating_at(shift))
        sonar_ = ImagingSonar(cfg, np.random.default_rng(7))
        pings = [sonar_.ping(caster, ORIGIN, LEVEL, 0.1 * i).polar for i in range(3)]
        images.add(b"".join(p.tobytes() for p in pings))
    assert len(images) == 1


def test_the_coherent_pier_pings_are_the_same_whatever_the_heap_holds() -> None:
    """The case where it showed: the P900-45 at 20 m over the pier, 64 rays a beam, the
    coherent model (on main the sonars below gave two or three different images, by an
    ulp in a cell at a block of rows' head or tail)."""
    from uhrisim.world.paper_scenes import pier_scene

    paper = pier_scene()
    pose = paper.sonar_poses["approach"]
    caster = paper.scene.raycaster("embree")
    cfg = SonarConfig(preset="P900-45", range_max_m=20.0, rays_per_beam=64,
                      tilt_deg=pose.tilt_deg, mount_position_frd=(0.0, 0.0, 0.0),
                      rate_hz=10.0, speckle_model="coherent")  # fmt: skip
    images, held = set(), []
    for k in range(6):
        held.append(np.ones(4 * k + 1, np.float32))  # shifts what the next blocks follow
        sonar_ = ImagingSonar(cfg, np.random.default_rng(0))
        pings = [sonar_.ping(caster, pose.position_ned, pose.rotation, 0.1 * i).polar
                 for i in range(3)]  # fmt: skip
        images.add(b"".join(p.tobytes() for p in pings))
    assert len(images) == 1
