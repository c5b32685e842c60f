"""Gymnasium environments (optional extra ``[gym]``): learn to follow a diver.

Importing this package registers

* ``uhrisim/TrailDiver-v0``: sonar polar image (uint8) + own navigation + tracked contact;
* ``uhrisim/TrailDiverState-v0``: the relative state only (fast experiments).

Both are :class:`~uhrisim.envs.trail_diver.TrailDiverEnv`; their native vector envs
(N episodes in one process) are :class:`~uhrisim.envs.vector.TrailDiverVectorEnv` and
:class:`~uhrisim.envs.sonar_vector.TrailDiverSonarVectorEnv`; ``docs/envs.md`` documents the
spaces (units, frames), reward terms, termination and randomisation.
"""

from __future__ import annotations

from uhrisim.core.errors import MissingExtraError

try:
    import gymnasium
except ImportError as error:  # pragma: no cover - depends on the installed extras
    raise MissingExtraError('uhrisim.envs needs Gymnasium: pip install "uhrisim[gym]"') \
        from error

from uhrisim.envs.episodes import Randomization
from uhrisim.envs.task import RewardWeights
from uhrisim.envs.trail_diver import EnvArgumentError, TrailDiverEnv

ENTRY_POINT = "uhrisim.envs.trail_diver:TrailDiverEnv"
#: The native vector env of each observation (``vectorization_mode="vector_entry_point"``).
VECTOR_ENTRY_POINTS = {"sonar": "uhrisim.envs.sonar_vector:TrailDiverSonarVectorEnv",
                       "state": "uhrisim.envs.vector:TrailDiverVectorEnv"}
ENV_IDS = ("uhrisim/TrailDiver-v0", "uhrisim/TrailDiverState-v0")

for _env_id, _observation in zip(ENV_IDS, ("sonar", "state"), strict=True):
    if _env_id not in gymnasium.registry:
        gymnasium.register(id=_env_id, entry_point=ENTRY_POINT,
                           vector_entry_point=VECTOR_ENTRY_POINTS[_observation],
                           kwargs={"observation": _observation})

__all__ = ["ENV_IDS", "EnvArgumentError", "Randomization", "RewardWeights", "TrailDiverEnv"]
