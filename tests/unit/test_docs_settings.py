"""docs/settings.md is the parts' declarations as they are in the code."""

from __future__ import annotations

from pathlib import Path

from uhrisim.scenario.settings_doc import render

PAGE = Path(__file__).resolve().parents[2] / "docs" / "settings.md"


def test_settings_page_is_written_from_the_declarations() -> None:
    assert PAGE.read_text(encoding="utf-8") == render(), (
        "docs/settings.md is out of date: python -m uhrisim.scenario.settings_doc > "
        "docs/settings.md")
    assert "| `rays_per_beam` | — | 64 | in [2, 4096] |" in render()
