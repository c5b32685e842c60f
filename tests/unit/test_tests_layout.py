"""The test suite's own house rules: helpers live in tests/support (no test module imports
another), and the project's own modules are imported, never skipped when missing."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]


def _imports(path: Path) -> list[str]:
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            found.append("." * node.level + (node.module or ""))
        elif isinstance(node, ast.Import):
            found += [alias.name for alias in node.names]
    return found


def _skipped_modules(path: Path) -> list[str]:
    return [node.args[0].value for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "importorskip"
            and node.args and isinstance(node.args[0], ast.Constant)]


def test_helpers_are_in_support_and_no_test_imports_another() -> None:
    wrong = [f"{f.relative_to(TESTS)}: {m}" for f in sorted(TESTS.rglob("test_*.py"))
             for m in _imports(f)
             if m.startswith(("tests.unit", "tests.integration", "tests.regression",
                              "tests.properties", ".test_", "test_"))]
    assert not wrong, "move what these share into tests/support:\n" + "\n".join(wrong)


def test_the_projects_own_modules_are_never_skipped() -> None:
    skipped = [f"{f.relative_to(TESTS)}: {m}" for f in sorted(TESTS.rglob("*.py"))
               for m in _skipped_modules(f) if m == "uhrisim" or m.startswith("uhrisim.")]
    assert not skipped, "import these (a missing module is a failure):\n" + "\n".join(skipped)
    # not vacuous: optional third-party stacks are still skipped where absent
    assert any("rclpy" in _skipped_modules(f) for f in TESTS.rglob("test_ros2_*.py"))


def test_xdist_workers_draw_ros_domains_from_disjoint_shares(monkeypatch) -> None:
    """Two ROS 2 modules running at once in two workers never share a domain (in one they
    read each other's topics); together the workers use every id of 1-101."""
    from tests.support.ros2_domains import spare_domain_id, worker_domain_ids

    for workers in (2, 3):
        monkeypatch.setenv("PYTEST_XDIST_WORKER_COUNT", str(workers))
        shares = []
        for worker in range(workers):
            monkeypatch.setenv("PYTEST_XDIST_WORKER", f"gw{worker}")
            shares.append(set(worker_domain_ids()))
            # a module's spare domain (a test apart from its module's readers): its share
            spares = {d: spare_domain_id(d) for d in shares[-1]}
            assert set(spares.values()) == shares[-1] and all(d != e for d, e in spares.items())
        assert sum(map(len, shares)) == 101 and set.union(*shares) == set(range(1, 102))
    monkeypatch.delenv("PYTEST_XDIST_WORKER")
    monkeypatch.delenv("PYTEST_XDIST_WORKER_COUNT")
    assert worker_domain_ids() == range(1, 102)
