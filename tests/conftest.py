"""Test-suite settings: property tests are derandomized (the same examples every run, on
every machine) and have no per-example deadline (CI machines are shared and slow); every
test fails that reads a path beside the repository (tests/support/repository_bounds.py);
every integration test is marked ``slow`` (missions, child processes, real ROS 2 and MOOS
peers, a browser), as is any other test that says so itself: ``make test-fast`` runs the
rest (``pytest -m "not slow"``). Both run a module's tests in one worker (``-n 2 --dist
loadscope``), so that a module-scoped fixture is set up once. Compiled kernels are cached
inside the repository (``.cache/numba``), for the suite and the processes it starts.
Under xdist the summary says how long each worker was busy and when its last test ended
(the gap between them is time one core sat idle at the end) and which modules took
longest: where to look first when the suite must get shorter or better balanced."""

import os
import time
from pathlib import Path

import pytest
from hypothesis import settings

from tests.support import repository_bounds

settings.register_profile("uhrisim", derandomize=True, deadline=None, print_blob=True)
settings.load_profile("uhrisim")

repository_bounds.install()
REPOSITORY = Path(__file__).resolve().parent.parent
os.environ.setdefault("NUMBA_CACHE_DIR", str(REPOSITORY / ".cache" / "numba"))


@pytest.fixture(autouse=True)
def _reads_stay_in_the_repository():
    """Fail a test that opened or listed anything beside the repository (a bare clone
    has nothing there: copy what a test needs into tests/data/ with its provenance)."""
    start = len(repository_bounds.offences)
    yield
    seen = repository_bounds.offences[start:]
    del repository_bounds.offences[start:]
    if seen:
        pytest.fail(f"read outside the repository ({len(seen)}×), first: {seen[0]}")


INTEGRATION = Path(__file__).parent / "integration"


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if INTEGRATION in item.path.parents:
            item.add_marker(pytest.mark.slow)


_WORKERS: dict[str, list[float]] = {}  # worker id -> [busy s, end of its last report (s)]
_MODULES: dict[str, float] = {}  # test module -> its tests' setup, call and teardown (s)
_SESSION_START = time.monotonic()


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """In the xdist controller: add each worker's reported test phases to its timeline
    and to its module's total."""
    node = getattr(report, "node", None)  # set only on reports a worker sent
    if node is not None:
        busy = _WORKERS.setdefault(node.gateway.id, [0.0, 0.0])
        busy[0] += report.duration
        busy[1] = time.monotonic() - _SESSION_START
        module = report.nodeid.split("::")[0]
        _MODULES[module] = _MODULES.get(module, 0.0) + report.duration


def pytest_terminal_summary(terminalreporter) -> None:
    if len(_WORKERS) > 1:
        ends = [end for _, end in _WORKERS.values()]
        terminalreporter.write_line("workers: " + "; ".join(
            f"{name} busy {busy:.0f} s, done at {end:.0f} s"
            for name, (busy, end) in sorted(_WORKERS.items()))
            + f" (one idle for the last {max(ends) - min(ends):.0f} s)")
        longest = sorted(_MODULES.items(), key=lambda item: -item[1])[:15]
        terminalreporter.write_line("longest modules: " + ", ".join(
            f"{Path(module).stem} {seconds:.0f} s" for module, seconds in longest))
