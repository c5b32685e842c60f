"""The example missions shipped inside the package (``uhrisim/scenarios``: the demo, the
benchmarks, the figures), found with ``importlib.resources`` so that a plain
``pip install`` runs them; a checkout's ``scenarios/`` folder is a link to the same files.

``uhrisim scenarios`` lists them and ``uhrisim scenarios copy NAME DIR`` copies one, with
the behavior and MOOS files it names, to edit.
"""

from __future__ import annotations

import shutil
from importlib import resources
from pathlib import Path

import yaml

from uhrisim.core.errors import ConfigError

#: The files a scenario may name beside it (helm behaviors, MOOS missions, launch scripts).
COMPANION_SUFFIXES = (".bhv", ".moos", ".sh")


def scenarios_dir() -> Path:
    """The folder of shipped scenarios inside the installed package."""
    folder = resources.files("uhrisim").joinpath("scenarios")
    if not isinstance(folder, Path) or not folder.is_dir():
        raise ConfigError(f"the shipped scenarios are missing from the installed package "
                          f"({folder}): reinstall uhrisim (pip install --force-reinstall)")
    return folder


def shipped_scenarios() -> list[str]:
    """Names of the shipped scenario files, relative to the scenarios folder, sorted."""
    root = scenarios_dir()
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*.yaml"))


def shipped_scenario(name: str = "track_and_trail.yaml") -> Path:
    """Path of a shipped scenario (``name`` with or without ``.yaml``); a clear error
    naming the available ones when there is none of that name."""
    file_name = name if name.endswith(".yaml") else f"{name}.yaml"
    path = scenarios_dir() / file_name
    if not path.is_file():
        raise ConfigError(f"no shipped scenario named {name!r}; available: "
                          f"{', '.join(shipped_scenarios())} (uhrisim scenarios)")
    return path


def copy_scenario(name: str, destination: Path) -> list[Path]:
    """Copy the shipped scenario ``name`` and the files it names beside it (behaviors, MOOS
    missions, a scenario a sweep runs) into ``destination``; the paths written. Refuses
    to overwrite an existing file."""
    source = shipped_scenario(name)
    root = scenarios_dir()
    wanted = [source, *_companions(source, root)]
    targets = [destination / p.relative_to(root) for p in wanted]
    existing = [t for t in targets if t.exists()]
    if existing:
        raise ConfigError(f"{existing[0]} exists: copy into an empty folder or remove it")
    for src, target in zip(wanted, targets, strict=True):
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, target)
    return targets


def _companions(scenario: Path, root: Path) -> list[Path]:
    """The shipped files the scenario names (in its text or its comments), and those the
    named files' own settings name in turn (``behaviors: videoray_trail.bhv``,
    ``scenario: ../track_and_trail.yaml``, a MOOS file's ``behaviors = ...``)."""
    candidates = [p for p in sorted(root.rglob("*"))
                  if p.is_file() and p.suffix in (*COMPANION_SUFFIXES, ".yaml")]
    found: list[Path] = []
    pending = [(scenario, scenario.read_text())]
    while pending:
        _, text = pending.pop()
        for candidate in candidates:
            if candidate != scenario and candidate not in found and candidate.name in text:
                found.append(candidate)
                pending.append((candidate, _without_comments(candidate.read_text())))
    return found


def _without_comments(text: str) -> str:
    """``text`` without its ``#`` (YAML, shell) and ``//`` (behavior, MOOS) comments."""
    return "\n".join(line.split("//")[0].split("#")[0] for line in text.splitlines())


def scenario_summary(path: Path) -> str:
    """What a shipped file is, in a line: its ``description`` (the first line of it), else
    its opening comment's first line without the parenthesis."""
    data = yaml.safe_load(path.read_text())
    text = data.get("description", "") if isinstance(data, dict) else ""
    if not text:
        first = path.read_text().splitlines()[0]
        text = first.lstrip("# ").split(" (")[0] if first.startswith("#") else ""
    return " ".join(text.split())
