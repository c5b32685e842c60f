"""The kinds of tool a scenario may place (:mod:`uhrisim.world.tools` holds their
catalogue and meshes). A module of its own so that the scenario schema names the kinds
without importing the meshes (trimesh)."""

TOOL_KINDS = ("wrench", "hammer", "light", "lift_bag", "tool_basket")
