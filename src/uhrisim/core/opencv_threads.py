"""OpenCV on one thread in the ``uhrisim`` command (a process-wide setting at the edge).

uhrisim's OpenCV passes run on small images — a sonar ping's polar image (≤ 0.3 Mpx), a
320×240 camera frame, the readers' crops — many times a simulated second. OpenCV's own
thread pool splits each pass over the cores and its threads wait for the next one, which
costs more CPU than the split saves: measured on the 2-core development machine (idle,
2026-11-27), the paper's mission with the sonar ran 34× real time per CPU second with
OpenCV's default two threads and 49–55× with one (wall time 45× → 49–55× too); the
assisted salvage 5.0× → 6.9× per CPU second (wall 6.2× → 6.9×); the camera's 320×240
frames 136 → 168 per CPU second (wall unchanged). docs/performance.md has the runs.

Like :mod:`uhrisim.core.memory` this changes process-wide state, so the library never
does it on import: the ``uhrisim`` command calls :func:`one_opencv_thread` at start; a
program embedding the simulator may call it too. A value already in the environment
wins (``OPENCV_FOR_THREADS_NUM=2 uhrisim run …``).
"""

from __future__ import annotations

import os
import sys

#: The environment variable OpenCV reads for its thread count when it is first imported.
OPENCV_THREADS_VARIABLE = "OPENCV_FOR_THREADS_NUM"


def one_opencv_thread() -> bool:
    """Ask OpenCV for one thread unless the environment already names a count; applied
    at once if OpenCV is imported already. Returns True when this call set it."""
    if OPENCV_THREADS_VARIABLE in os.environ:
        return False
    os.environ[OPENCV_THREADS_VARIABLE] = "1"  # read by cv2 at import; children inherit it
    if "cv2" in sys.modules:
        sys.modules["cv2"].setNumThreads(1)
    return True
