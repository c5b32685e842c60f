"""Nothing in the project reads outside the repository: a bare clone must pass.

Two guards: the runtime one (tests/support/repository_bounds.py, every test's opens), and
this static scan of what runs in other processes too (src/, tests/, the Makefile, CI):
no path to a sibling folder of the repository, no ``__file__`` walked above the root.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from tests.support import repository_bounds
from tests.support.repository_bounds import REPO, outside_repository

# the team's reference folder beside a clone, as a path would spell it (a relative path,
# a path component of its own, the old override variable); the notes the code cites are
# in the repository (docs/reference/sonar.md, tests/unit/test_docs_citations.py)
_SIBLING_PATH = re.compile(r"\.\./shar[e]d|[\"']shar[e]d[\"']|UHRISIM_REFERENCE_DI[R]")


def _project_files() -> list[Path]:
    files = [*(REPO / "src").rglob("*.py"), *(REPO / "tests").rglob("*.py")]
    files += [REPO / "Makefile", *(REPO / ".ci").iterdir()]
    return sorted(f for f in files if f.is_file())


def _levels_up(node: ast.AST) -> int | None:
    """How many folders above ``__file__``'s own folder an expression climbs, for
    ``Path(__file__)...parents[k]`` (k + 1) and ``...parent.parent`` (one less than the
    count); None when the expression does not start at ``__file__``."""
    up = 0
    while True:
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Attribute) and (
            node.value.attr == "parents" and isinstance(node.slice, ast.Constant)
        ):
            up += int(node.slice.value) + 1
            node = node.value.value
        elif isinstance(node, ast.Attribute) and node.attr == "parent":
            up += 1
            node = node.value
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and (
            node.func.attr in ("resolve", "absolute")
        ):
            node = node.func.value
        elif isinstance(node, ast.Call) and node.args:  # Path(__file__)
            node = node.args[0]
        else:
            return up - 1 if isinstance(node, ast.Name) and node.id == "__file__" else None


def test_no_file_names_a_folder_beside_the_repository():
    hits = []
    for f in _project_files():
        for i, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1):
            if _SIBLING_PATH.search(line) and f != Path(__file__).resolve():
                hits.append(f"{f.relative_to(REPO)}:{i}: {line.strip()}")
    assert not hits, "paths beside the repository:\n" + "\n".join(hits)


@pytest.mark.slow
def test_no_module_climbs_above_the_repository_root():
    hits = []
    for f in _project_files():
        if f.suffix != ".py":
            continue
        depth = len(f.relative_to(REPO).parts) - 1  # folders between the root and f
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            up = _levels_up(node)
            if up is not None and up > depth:
                hits.append(f"{f.relative_to(REPO)}:{node.lineno}: {ast.unparse(node)}")
    assert not hits, "paths above the repository root:\n" + "\n".join(hits)


def test_climb_count_reads_the_usual_spellings():
    here = "Path(__file__).resolve()"
    assert _levels_up(ast.parse(f"{here}.parents[2]").body[0].value) == 2
    assert _levels_up(ast.parse(f"{here}.parent.parent").body[0].value) == 1
    assert _levels_up(ast.parse("Path(__file__).parent").body[0].value) == 0
    assert _levels_up(ast.parse("Path(x).parents[3]").body[0].value) is None


def test_runtime_guard_sees_a_read_beside_the_repository():
    probe = REPO.parent / "uhrisim-bounds-probe-does-not-exist"
    # in the temporary folder only the neighbours there at start count (repository_bounds)
    assert outside_repository(probe) == (REPO.parent != REPO and not repository_bounds._IN_TEMP)
    assert not outside_repository(REPO / "tests" / "data")
    assert not outside_repository(REPO / ".." / REPO.name / "README.md")
    assert not outside_repository("/proc/self/status")
    start = len(repository_bounds.offences)
    with pytest.raises(FileNotFoundError):
        probe.open()
    seen = repository_bounds.offences[start:]
    del repository_bounds.offences[start:]  # the probe is this test's own, not a fault
    if REPO.parent != REPO and not repository_bounds._IN_TEMP:
        assert seen == [f"open {probe}"]
