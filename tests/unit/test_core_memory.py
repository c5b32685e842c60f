"""keep_freed_memory: freed megabyte-sized arrays are reused, not faulted in again."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

CHURN = textwrap.dedent(
    """
    import resource, sys
    import numpy as np
    from uhrisim.core.memory import keep_freed_memory
    if sys.argv[1] == "keep":
        assert keep_freed_memory()
    def faults():
        return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for size in (300_000, 1_000_000, 3_000_000):  # settle whatever glibc adapts
        np.ones(size)
    before = faults()
    for _ in range(50):  # a ping's pattern: big temporaries made, used, freed
        a = np.ones(400_000)
        b = a * 2.0
        del a, b
    print(faults() - before)
    """
)


def _faults(mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", CHURN, mode], capture_output=True, text=True,
                         check=True, timeout=120)  # fmt: skip
    return int(out.stdout.strip())


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt only")
def test_freed_arrays_are_reused_without_page_faults() -> None:
    # 50 rounds of two 3.2 MB arrays are 80 000 pages: reused, they fault almost never.
    assert _faults("keep") < 100
