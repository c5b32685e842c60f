"""Writes ``mission_decisions.npz``: every helm decision of the paper's mission
(scenarios/track_and_trail.yaml, no sonar, 600 s, both helms at 4 Hz) as the helm made
them before its pieces were cached (commit f8612a8 on main).
tests/integration/test_helm_decision_audit.py holds today's helm to them, decision for
decision. Run from the repository root with the package installed (only to re-create it
deliberately): ``python tests/data/helm/make_mission_decisions.py``."""

from pathlib import Path

import numpy as np

from uhrisim.scenario.load import load_scenario
from uhrisim.scenario.shipped import shipped_scenario
from uhrisim.sim.simulation import BaseHook, Simulation

MISSION_S = 600.0


class Decisions(BaseHook):
    """Collects (tick, agent index, heading, speed, depth) of every helm record."""

    def __init__(self, names: list[str]) -> None:
        self.names = names
        self.rows: list[tuple[float, ...]] = []

    def on_tick(self, frame) -> None:
        for name, record in frame.helm.items():
            self.rows.append((frame.tick, self.names.index(name),
                              np.nan if record.heading_deg is None else record.heading_deg,
                              np.nan if record.speed is None else record.speed,
                              np.nan if record.depth is None else record.depth))


def mission_decisions(seconds: float = MISSION_S) -> np.ndarray:
    """Rows (tick, agent index in the scenario, heading deg, speed m/s, depth m)."""
    source = load_scenario(shipped_scenario())
    hook = Decisions([a.name for a in source.scenario.agents])
    with Simulation(source, raycast_sensors=False, hooks=[hook]) as sim:
        sim.run(seconds)
    return np.array(hook.rows)


if __name__ == "__main__":
    path = Path(__file__).with_name("mission_decisions.npz")
    rows = mission_decisions()
    np.savez_compressed(path, decisions=rows)
    print(f"wrote {path}: {len(rows)} decisions")
