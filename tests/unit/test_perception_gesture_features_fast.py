"""The gesture reader's per-frame step (perception/gesture_reader.py: integer bin sums,
a running median by partition, OpenCV's dilation, components and box sum) held bit for
bit to the scipy reference it replaced, kept here: silhouettes and frame descriptors of
pictures with a figure, specks and noise from none to turbid water's, binned by 1, 2 and
3. (The same held on the 400 frames of the assisted salvage's first 40 s.)"""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy import ndimage

from uhrisim.perception import gesture_reader as g


def reference_silhouette(rgb):
    """perception/gesture_reader.py's silhouette before it was made faster (with each
    row's own spread since SILHOUETTE_VERSION 2)."""
    image = rgb.astype(np.float32)
    factor = max(1, math.ceil(image.shape[1] / g.MAX_COLUMNS))
    if factor > 1:
        h, w = (image.shape[0] // factor) * factor, (image.shape[1] // factor) * factor
        image = image[:h, :w].reshape(h // factor, factor, w // factor, factor, -1).mean(
            axis=(1, 3))
    coarse = ndimage.median_filter(image[:, ::g.BACKGROUND_STEP],
                                   size=(1, g.BACKGROUND_PX // g.BACKGROUND_STEP + 1, 1),
                                   mode="nearest")
    background = np.repeat(coarse, g.BACKGROUND_STEP, axis=1)[:, :image.shape[1]]
    residual = np.abs(image - background)
    sigma = np.maximum(1.4826 * np.median(residual, axis=(0, 1)), 1.0)
    sigma = np.maximum(sigma, 1.4826 * np.median(residual, axis=1, keepdims=True))
    mask = (residual > np.maximum(g.THRESHOLD_SIGMA * sigma, g.MIN_LEVELS)).any(axis=2)
    labels, n = ndimage.label(ndimage.binary_dilation(mask, iterations=g.GROUP_PX))
    if n == 0:
        return mask
    sizes = np.bincount(labels[mask], minlength=n + 1)
    keep = sizes >= max(g.MIN_AREA_PX, g.KEEP_SHARE * sizes[1:].max())
    keep[0] = False
    return mask & keep[labels]


def reference_neighbours(mask):
    """The descriptor's count of set pixels in each 3 × 3 neighbourhood, as it was."""
    return ndimage.convolve(mask.astype(np.uint8), np.ones((3, 3), np.uint8), mode="constant")


def pictures():
    """Pictures of what the reader meets: water whose veil darkens with depth and
    bends along a horizon, a floor below it (rippled in two of them), a figure (trunk,
    head, an arm out, a leg), specks, and the camera's noise from none to turbid
    water's; one of noise alone."""
    rng = np.random.default_rng(26)
    rows, cols = np.mgrid[0:240, 0:320]
    out = []
    for noise, arm, ripples in ((0.0, 40, 0.0), (2.0, 70, 0.0), (6.0, 25, 0.0),
                                (12.0, 55, 0.0), (30.0, 60, 0.0), (0.0, 40, 15.0),
                                (4.0, 55, 25.0)):
        veil = 90.0 - 0.2 * rows + 8.0 * np.sin(cols / 50.0)
        horizon = rows > 150 + 10.0 * np.cos(cols / 80.0)
        floor = horizon * (25.0 + ripples * np.sin(2 * np.pi * cols / 7.0))
        picture = np.stack([veil * 0.3, veil * 0.8, veil], axis=-1) + floor[..., None]
        figure = ((abs(cols - 160) < 12) & (rows > 80) & (rows < 170)
                  | ((cols - 160) ** 2 + (rows - 70) ** 2 < 100)
                  | ((cols > 160) & (cols < 160 + arm) & (abs(rows - 95) < 3))
                  | ((abs(cols - 150) < 4) & (rows >= 170) & (rows < 215)))
        picture[figure] = (20.0, 25.0, 30.0)
        specks = rng.integers(0, 240, (6, 2))
        picture[specks[:, 0], specks[:, 1] + 40] = 200.0
        picture += rng.normal(0.0, noise, picture.shape)
        out.append(np.clip(np.rint(picture), 0, 255).astype(np.uint8))
    out.append(rng.integers(50, 70, (240, 320, 3), dtype=np.uint8))
    return out


def test_silhouettes_and_descriptors_are_the_reference_bit_for_bit():
    found = 0
    for rgb in pictures():
        for picture in (rgb, rgb[:, ::2], cv2.resize(rgb, (480, 240),
                                                     interpolation=cv2.INTER_NEAREST)):
            mask = g.silhouette(picture)
            assert np.array_equal(mask, reference_silhouette(picture))
            assert np.array_equal(cv2.boxFilter(mask.astype(np.uint8), -1, (3, 3),
                                                normalize=False,
                                                borderType=cv2.BORDER_CONSTANT),
                                  reference_neighbours(mask))
            assert np.array_equal(g.frame_descriptor(picture),
                                  g.silhouette_descriptor(reference_silhouette(picture)),
                                  equal_nan=True)
            found += mask.any()
    assert found >= 16  # a figure was there to find, in most
