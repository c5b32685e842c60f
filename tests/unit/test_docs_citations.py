"""Every path the code and the docs cite exists in the repository.

Scanned: the Python of src/ and tests/, the Markdown of docs/ (but the reference notes,
which quote other projects' files), README.md and the scenarios. A citation is a path that
starts at a top folder of the repository and names a file (``docs/sonar.md``,
``src/uhrisim/vehicles.py``, ``scenarios/track_and_trail.yaml``) or a Markdown link of a
page (relative to the page); a glob, a placeholder (``*``, ``<agent>``) or an error
message's ``file:line`` is not checked. Nothing may cite the
team's notes outside the repository (their design notes and reference folder): they are
docs/design.md and docs/reference/ here.
"""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
TOP = ("docs", "src", "tests", "scenarios", "examples")
_CITED = re.compile(r"(?<![\w./-])((?:" + "|".join(TOP) + r")/[\w./-]*\.\w+)(?![\w*<{/]|:\d)")
_LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
_OUTSIDE = re.compile(r"DESIGN\.md|shared/reference|\.\./shared")


def _scanned() -> list[Path]:
    files = [*(REPO / "src").rglob("*.py"), *(REPO / "tests").rglob("*.py"),
             *(REPO / "docs").rglob("*.md"), REPO / "README.md",
             *(REPO / "scenarios").rglob("*.yaml")]
    return sorted(f for f in files if "reference" not in f.relative_to(REPO).parts[:2]
                  and f != Path(__file__))


def _missing(path: Path, cited: str, base: Path) -> bool:
    if any(c in cited for c in "*<>{}$"):
        return False
    target = (base / cited).resolve()
    return not target.exists()


def test_every_cited_path_exists() -> None:
    missing, checked = [], 0
    for f in _scanned():
        text = f.read_text(encoding="utf-8")
        for n, line in enumerate(text.splitlines(), 1):
            for cited in _CITED.findall(line):
                checked += 1
                if _missing(f, cited, REPO):
                    missing.append(f"{f.relative_to(REPO)}:{n}: {cited}")
            if f.suffix == ".md":
                for link in _LINK.findall(line):
                    checked += 1
                    if "://" not in link and _missing(f, link, f.parent):
                        missing.append(f"{f.relative_to(REPO)}:{n}: ({link})")
    assert not missing, "cited paths that do not exist:\n" + "\n".join(missing)
    assert checked > 300  # the scan reads citations (not vacuous)


def test_nothing_cites_notes_outside_the_repository() -> None:
    found = [f"{f.relative_to(REPO)}:{n}: {line.strip()}" for f in _scanned()
             for n, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1)
             if _OUTSIDE.search(line) and "Provenance" not in line]
    assert not found, "cite docs/design.md and docs/reference/ instead:\n" + "\n".join(found)


def test_the_scan_sees_citations() -> None:
    """Not vacuous: known citations of each kind are found."""
    line = "see docs/reference/sonar.md, src/uhrisim/vehicles.py and [x](layout.md)"
    assert _CITED.findall(line) == ["docs/reference/sonar.md", "src/uhrisim/vehicles.py"]
    assert _LINK.findall(line) == ["layout.md"]
    assert _missing(REPO / "README.md", "docs/nonexistent.md", REPO)
    assert len(_scanned()) > 200
