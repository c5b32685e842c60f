"""The scenario's teamwork fields (uhrisim.scenario.teamwork): orders become the
executor's orders, and bad ones are refused at load with their file line."""

from __future__ import annotations

from pathlib import Path

import pytest

from uhrisim.core.errors import ConfigError
from uhrisim.scenario.load import load_scenario
from uhrisim.teamwork import orders as od

HEAD = """name: t
world:
  seafloor: {type: flat, depth: 12}
  tools:
    - {kind: wrench, name: wrench1, at: {north: 1, east: 0}}
agents:
  - name: diver1
    model: diver_boots
    driver: orders
    orders:
"""


def load(tmp_path: Path, orders: str, head: str = HEAD):
    path = tmp_path / "s.yaml"
    path.write_text(head + orders)
    return load_scenario(path)


def test_orders_become_the_executors_orders(tmp_path):
    source = load(tmp_path, "      - {pick_up: wrench1, hand: left}\n"
                            "      - {use: wrench1, at: flange1, seconds: 8, bolt: 2}\n"
                            "      - {remove: flange1, part: cover}\n"
                            "      - {put_down: wrench1, onto: stand1}\n"
                            "      - {hand: wrench1, to: rov1/gripper}\n"
                            "      - {wait_until: valve1, state: lifted, timeout_s: 30}\n"
                            "      - {go_to: [1.0, 2.0]}\n"
                            "      - {signal: ok}\n")
    orders = [o.order() for o in source.scenario.agents[0].orders]
    assert orders == [od.PickUp("wrench1", "left"), od.UseOn("wrench1", "flange1", 8.0, 2),
                      od.Remove("flange1", "cover"), od.PutDown("wrench1", "stand1"),
                      od.HandTo("wrench1", "rov1/gripper"),
                      od.WaitUntil("valve1", "lifted", 30.0), od.GoTo((1.0, 2.0), 0.6),
                      od.Signal("ok", 2.0)]


@pytest.mark.parametrize("order,message", [
    ("{grab: wrench1}", "an order is a mapping whose first key is one of go_to, pick_up"),
    ("{use: wrench1, at: flange1, seconds: -1}", "seconds"),
    ("{signal: wave}", "signal"),
])
def test_a_bad_order_is_refused_at_its_line(tmp_path, order, message):
    with pytest.raises(ConfigError, match=rf"s\.yaml:11: agents\[0\]\.orders\[0\].*{message}"):
        load(tmp_path, f"      - {order}\n")


def test_a_walking_diver_needs_a_floor_and_orders_need_their_driver(tmp_path):
    with pytest.raises(ConfigError, match=r"walks on the sea floor: give the scenario a "
                                          r"world\.seafloor"):
        load(tmp_path, "      - {signal: ok}\n", HEAD.replace(
            "  seafloor: {type: flat, depth: 12}\n", ""))
    with pytest.raises(ConfigError, match="'orders' go with driver: orders"):
        load(tmp_path, "      - {signal: ok}\n", HEAD.replace("driver: orders", "driver: none"))
