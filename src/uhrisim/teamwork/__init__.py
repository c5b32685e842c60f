"""Teamwork: divers and the ROV acting on a world that changes.

The models beside the vehicles — tools and work sites (:mod:`uhrisim.world.tools`,
:mod:`uhrisim.world.worksites`), the articulated diver
(:mod:`uhrisim.dynamics.diver_body`) — come together here: the ROV's gripper
(:mod:`.gripper`), the workspace that records where every object is and who holds it
(:mod:`.workspace`), the rules of the acts (:mod:`.acts`), and order-based diver scripts
with their executor and validator (:mod:`.orders`, :mod:`.executor`). docs/teamwork.md
describes them and how the simulation wires them in.

Layer: above the models (it imports dynamics and world), below scenario and sim.
"""
