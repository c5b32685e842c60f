"""A diver waiting for a tool from the ROV rises upright (sim/assistance.py,
SignallingDiver.signalling_pose): prone, his head lies ahead of his body where the ROV's
jaws must reach his hand, inside its head guard (docs/hri.md, "The assisted salvage,
measured")."""

from __future__ import annotations

from uhrisim.perception.signalling import SignalPerformer
from uhrisim.sim.assistance import SignallingDiver


def test_a_diver_waiting_for_a_tool_rises_upright_and_otherwise_keeps_his_pose():
    diver = SignallingDiver(agent=None, performer=SignalPerformer())  # type: ignore[arg-type]
    assert diver.signalling_pose(10.0) is None  # neither signalling nor receiving
    diver.receiving = True
    assert diver.signalling_pose(10.0) == {"posture": 0.0, "waist": 0.0}
