"""The ``uhrisim`` command runs OpenCV on one thread unless the environment says otherwise
(src/uhrisim/core/opencv_threads.py): OpenCV itself, in a fresh process, is the judge."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from uhrisim.core.opencv_threads import OPENCV_THREADS_VARIABLE

pytest.importorskip("cv2")

#: A fresh process: the setting made before OpenCV is imported, then OpenCV's own count.
PROBE = ("from uhrisim.core.opencv_threads import one_opencv_thread\n"
         "print(one_opencv_thread())\n"
         "import cv2\n"
         "print(cv2.getNumThreads())\n")
#: The same with OpenCV imported first: the count is applied at once.
PROBE_IMPORTED = "import cv2\n" + PROBE


def _probe(code: str, **env: str) -> list[str]:
    base = {k: v for k, v in os.environ.items() if k != OPENCV_THREADS_VARIABLE}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=base | env, timeout=120, check=True)
    return done.stdout.split()


@pytest.mark.parametrize("code", [PROBE, PROBE_IMPORTED])
def test_opencv_gets_one_thread(code):
    assert _probe(code) == ["True", "1"]


def test_a_count_in_the_environment_wins():
    assert _probe(PROBE, **{OPENCV_THREADS_VARIABLE: "2"}) == ["False", "2"]


def test_the_command_sets_it_for_what_it_runs():
    """``uhrisim validate`` (any command: the setting is the app's callback) leaves OpenCV
    one thread for what it imports afterwards."""
    code = ("import cv2, sys\n"
            "from uhrisim.cli import main\n"
            "from uhrisim.scenario.shipped import shipped_scenario\n"
            "print(main(['validate', str(shipped_scenario())]), file=sys.stderr)\n"
            "print(cv2.getNumThreads())\n")
    base = {k: v for k, v in os.environ.items() if k != OPENCV_THREADS_VARIABLE}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=base, timeout=120)
    assert done.returncode == 0 and done.stderr.splitlines()[-1] == "0", done.stderr
    assert done.stdout.split()[-1] == "1"
