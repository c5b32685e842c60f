"""The example missions in the repository's ``scenarios/`` folder (demo, benchmarks)."""

from __future__ import annotations

from pathlib import Path

from uhrisim.core.errors import ConfigError

SCENARIOS_DIR = Path(__file__).resolve().parents[3] / "scenarios"


def shipped_scenario(name: str = "track_and_trail.yaml") -> Path:
    """Path of a scenario shipped with the source tree; a clear error outside a checkout."""
    path = SCENARIOS_DIR / name
    if not path.is_file():
        raise ConfigError(f"{path} not found: the example scenarios live in the source "
                          "tree's scenarios/ folder; run from a checkout (e.g. make demo)")
    return path
