"""The bubble plumes of the scenario's divers (``agents[].bubbles``) in the scene.

Each diver with a ``bubbles`` section gets a :class:`~uhrisim.world.bubbles.BubblePlume`
(random stream ``"<agent>/bubbles"``) and a fixed set of dynamic bodies, one per bubble
cloud, labelled ``bubbles`` in the sonar's label images and named ``<agent>_bubbles_<i>``.
Bursts are released from the regulator (``regulator_frd`` on the diver's body) when due;
the clouds are posed whenever the scene is synchronised. Bubbles are no obstacles: the
collision checks leave them out.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from uhrisim.core.frames import rot_z
from uhrisim.sim.state import Agent
from uhrisim.world.bubbles import AIR_BUBBLE, PARKED_NED, BubblePlume, cluster_mesh
from uhrisim.world.scene import Scene

BUBBLES_LABEL = "bubbles"
_EYE3 = np.eye(3)


class DiverBubbles:
    """The plumes of every diver that breathes bubbles, and their bodies in ``scene``."""

    def __init__(self, scene: Scene, agents: Mapping[str, Agent],
                 rng: Callable[[str], np.random.Generator]) -> None:
        self._scene = scene
        self._plumes: list[tuple[Agent, BubblePlume, list[str]]] = []
        for agent in agents.values():
            cfg = agent.config.bubbles
            if cfg is None:
                continue
            stream = rng(f"{agent.name}/bubbles")
            plume = BubblePlume(cfg.params(), stream)
            names = [f"{agent.name}_bubbles_{i}" for i in range(plume.n_clouds)]
            for name in names:
                scene.add_dynamic(name, cluster_mesh(plume.params, stream), BUBBLES_LABEL,
                                  AIR_BUBBLE, PARKED_NED)
            self._plumes.append((agent, plume, names))
        self.body_names = frozenset(n for _, _, names in self._plumes for n in names)
        #: does any diver breathe out bubbles? (else the loop skips :meth:`release`)
        self.active = bool(self._plumes)

    def release(self, t: float) -> None:
        """Release the bursts due by ``t`` (s) at each diver's regulator."""
        for agent, plume, _ in self._plumes:
            while t >= plume.next_burst_time():
                nav = agent.nav()
                origin = nav.position_ned + rot_z(nav.yaw) @ np.asarray(
                    plume.params.regulator_frd)
                plume.release(plume.next_burst_time(), origin)

    def pose(self, t: float) -> None:
        """Move the clouds' bodies to where they are at ``t`` (s)."""
        for _, plume, names in self._plumes:
            for name, position in zip(names, plume.positions(t), strict=True):
                self._scene.set_pose(name, position, _EYE3)
