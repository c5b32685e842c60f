"""Scene labels of a ping's images: which object each polar cell and fan pixel shows.

Labels are the scene's label ids (``Scene.labels`` indexes them); −1 means no echo. A
polar cell takes the label that put the most echo into it (:class:`CellLabeller`); the
fan's labels are the polar labels scan-converted nearest-neighbour, with every hit then
splatted at its own pixel so thin returns survive (:class:`FanLabeller`). With labels off
every ping shares one read-only "no label" image (:func:`unlabelled`). Both labellers keep
scratch buffers between pings.
"""

from __future__ import annotations

import threading

import cv2
import numpy as np
from numpy.typing import NDArray

from uhrisim.sensors.sonar.geometry import SonarGeometry


def unlabelled(shape: tuple[int, ...]) -> NDArray[np.int16]:
    """A read-only label image of ``shape``, all −1 (no label), shared by many pings."""
    image = np.full(shape, -1, np.int16)
    image.setflags(write=False)
    return image


class CellLabeller:
    """Labels the (range bin, beam) cells of a raw echo image of ``n_cells`` cells."""

    def __init__(self, n_cells: int) -> None:
        self._energy = np.zeros(n_cells, np.float64)
        self._total = np.zeros(n_cells, np.float64)
        self._best = np.zeros(n_cells, np.float64)
        self._best_label = np.full(n_cells, -1, np.int16)
        self._mark = np.zeros(n_cells, np.bool_)

    def label(
        self,
        raw: NDArray[np.float32],
        out: NDArray[np.int16],
        labels: NDArray[np.int32],
        a: NDArray[np.float64],
        b: NDArray[np.float64],
        lo: NDArray[np.int64],
        hi: NDArray[np.int64],
        dens: NDArray[np.float64],
        e: NDArray[np.float64],
        beam: NDArray[np.int64],
    ) -> None:
        """Fill ``out`` (n_bins, n_beams) with the label that put the most echo in each
        cell of the raw echo image ``raw``: the footprints [a, b) (fractional bins, first
        and last bin ``lo``, ``hi``, echo per bin ``dens``, ``e`` for a footprint inside one
        bin) of rays with scene ``labels`` in beams ``beam``; see
        :meth:`~uhrisim.sensors.sonar.echoes.EchoAccumulator.accumulate`."""
        n_beams = raw.shape[1]
        present = np.bincount(labels + 1)
        background = int(np.argmax(present)) - 1
        # out = background where raw > 0, else −1 (a look-up on OpenCV's 0/255 mask).
        lut = np.full(256, -1, np.int16)
        lut[255] = background
        cv2.LUT(cv2.compare(raw, 0.0, cv2.CMP_GT), lut, dst=out)
        others = [int(v) - 1 for v in np.flatnonzero(present) if int(v) - 1 != background]
        if not others:
            return
        # Sparse per-cell sums in persistent scratch buffers that are all zero (−1, False)
        # between pings: add, read, reset only the touched cells, so the cost follows the
        # foreground footprints, not the image size.
        oflat = out.reshape(-1)
        rflat = raw.reshape(-1)
        acc = self._energy
        mark = self._mark
        best = self._best
        best_lab = self._best_label
        total = self._total
        touched = []
        for lab in others:
            sel = np.flatnonzero(labels == lab)
            n_c = hi[sel] - lo[sel] + 1
            ray_of = np.repeat(sel, n_c)
            first = np.cumsum(n_c) - n_c
            row = np.arange(ray_of.size, dtype=np.int64) - np.repeat(first - lo[sel], n_c)
            w = np.minimum(b[ray_of], row + 1.0) - np.maximum(a[ray_of], row)
            w *= dens[ray_of]
            single = np.repeat(n_c == 1, n_c)
            w[single] = e[ray_of[single]]
            cells = row * n_beams + beam[ray_of]
            np.add.at(acc, cells, w)
            mark[cells] = True
            r0 = int(lo[sel].min()) * n_beams
            uniq = np.flatnonzero(mark[r0 : (int(hi[sel].max()) + 1) * n_beams]) + r0
            mark[uniq] = False
            energy = acc[uniq]  # this label's echo in each cell it touches
            acc[uniq] = 0.0
            total[uniq] += energy
            better = energy > best[uniq]
            best[uniq[better]] = energy[better]
            best_lab[uniq[better]] = lab
            touched.append(uniq)
        cells = np.concatenate(touched) if len(touched) > 1 else touched[0]
        # The strongest foreground label wins over the background's share (cell − all fg).
        win = cells[best[cells] > rflat[cells] - total[cells]]
        oflat[win] = best_lab[win]
        best[cells] = 0.0
        best_lab[cells] = -1
        total[cells] = 0.0


class FanLabeller:
    """Labels the pixels of the fan image of ``geometry`` (physical mode).

    A ping's fan is formed when first read, maybe on another thread: the strongest-echo
    scratch image of the splat is guarded by a lock.
    """

    def __init__(self, geometry: SonarGeometry) -> None:
        self.geometry = geometry
        # Strongest echo per fan pixel for the label splat: all zero between uses.
        self._pmax = np.zeros(geometry.fan_mask.size, np.float64)
        self._lock = threading.Lock()

    def label_fan(
        self,
        label_polar: NDArray[np.int16],
        cols_sonar: NDArray[np.float64],
        e: NDArray[np.float64],
        labels: NDArray[np.int32],
    ) -> NDArray[np.int16]:
        """Nearest-neighbour scan conversion of the polar labels, then each hit (sonar-frame
        points ``cols_sonar`` (3, M), m; echo ``e``) splatted at its own fan pixel
        (strongest wins), so thin returns survive the down-sampling."""
        g = self.geometry
        out = cv2.remap(
            label_polar,
            g.map_nearest,
            None,
            cv2.INTER_NEAREST,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=-1,
        )
        if e.size:
            H, W = out.shape
            col = np.floor(g.fan_apex[0] + 0.5 + cols_sonar[1] * g.fan_scale).astype(np.int64)
            row = np.floor(g.fan_apex[1] + 0.5 - cols_sonar[0] * g.fan_scale).astype(np.int64)
            ok = (col >= 0) & (col < W) & (row >= 0) & (row < H)
            pix = row[ok] * W + col[ok]
            ee = e[ok]
            with self._lock:
                pmax = self._pmax  # zeros; only the splatted pixels are reset
                np.maximum.at(pmax, pix, ee)
                win = ee >= pmax[pix]
                pmax[pix] = 0.0
            out.reshape(-1)[pix[win]] = labels[ok][win]
        return out
