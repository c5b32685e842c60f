"""The MOOS hook on a real simulation: NAV_* out at the link's rate, variables back in.

Expected numbers come from the simulation itself: NAV_X must equal the agent's NED east
and NAV_Y its north at the posted tick (docs/conventions.md), and the number of NAV_X
posts over N ticks is N / (physics rate / nav rate).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from tests.support.moos_ready import wait_registered
from uhrisim.bridges.moos import hook as hookmod
from uhrisim.bridges.moos.client import MoosClient
from uhrisim.bridges.moos.testdb import spawn
from uhrisim.scenario import load
from uhrisim.sim import simulation

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "track_and_trail.yaml"


def test_hook_posts_nav_and_feeds_variables_back():
    if not SCENARIO.exists():
        pytest.fail(f"{SCENARIO} is missing")
    source = load.load_scenario(SCENARIO)
    with spawn(community="videoray") as db:
        obs = MoosClient()
        obs.connect("127.0.0.1", db.port, "observer", strict=True)
        obs.register("NAV_X")
        obs.register("NODE_REPORT")
        wait_registered(obs)  # before the ROV's first posting
        link = hookmod.MoosAgentLink("videoray", port=db.port, community="videoray",
                                     nav_rate_hz=10.0, extra_vars=("RETURN",))
        hook = hookmod.MoosBridgeHook([link], time_source="sim", strict=True)
        sim = simulation.Simulation(source, hooks=[hook], seed=1, raycast_sensors=False)
        try:
            sim.start()
            assert sim.dt == pytest.approx(1 / 60)
            east_at: dict[float, float] = {}
            for _ in range(60):  # one simulated second; 10 Hz -> every 6th tick
                frame = sim.step()
                if frame.tick % 6 == 0:
                    east_at[round(frame.t, 6)] = float(
                        frame.agents["videoray"].nav.position_ned[1])
            obs.notify("RETURN", "true")
            obs.notify("DESIRED_SPEED", "not a number")  # dropped, must not reach the store
            obs.notify("DESIRED_DEPTH", float("nan"))  # dropped too
            deadline = time.monotonic() + 120.0  # only against a DB that hangs
            nav = []
            while not (sim.agents["videoray"].community.get("RETURN") == "true"
                       and len(nav) >= 10 and hook.n_rejected >= 2):
                assert time.monotonic() < deadline, (len(nav), hook.n_rejected)
                sim.step()
                nav += [m for m in obs.drain() if m.key == "NAV_X"]
                time.sleep(0.005)
            assert hook.n_rejected == 2
            assert isinstance(sim.agents["videoray"].community.get("DESIRED_SPEED", 0.0), float)
            t0 = hook.bridges["videoray"]._t0  # time_source="sim": stamp = t0 + t_sim
            checked = 0
            for m in nav:
                t_sim = m.time - t0  # ~1e-7 s rounding at epoch magnitudes
                near = [t for t in east_at if abs(t - t_sim) < 1e-3]
                if near:
                    assert m.value == pytest.approx(east_at[near[0]], abs=1e-9)
                    checked += 1
            assert checked == 10  # ticks 6, 12, ..., 60 within the first second
            assert hook.summary()["moos"]["videoray"]["connected"]
            assert any(e.kind == "bridge" for e in sim.events_log)
        finally:
            hook.on_end(sim, None)
            obs.close()
