"""uhrisim's own messages (``uhrisim_msgs``: HelmDecision, Variable, Event) serialised,
for the recorder and the live ROS 2 bridge alike.

Their definitions are :mod:`uhrisim.ros.msgdefs`' (embedded in every recording; the
live bridge builds the ROS 2 package from the same text,
:mod:`uhrisim.bridges.ros2.interfaces`); the bytes are CDR laid out by hand
(:mod:`uhrisim.ros.cdr`; a recording posts several of these every tick), held byte for
byte to ``mcap_ros2``'s schema-driven encoder by the tests. Each function checks its
input and raises a ConfigError naming ``where``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping

from uhrisim.core.errors import ConfigError
from uhrisim.ros import cdr

HELM_DECISION = "uhrisim_msgs/msg/HelmDecision"
VARIABLE = "uhrisim_msgs/msg/Variable"
EVENT = "uhrisim_msgs/msg/Event"


def helm_decision_bytes(t_ns: int, heading_deg: float | None, speed: float | None,
                        depth: float | None, contributions: Mapping[str, float], mode: str,
                        active: Iterable[str], total: float | None, all_stop_reason: str,
                        where: str) -> bytes:
    """One helm cycle as uhrisim_msgs/HelmDecision at ``t_ns`` (see
    :meth:`~uhrisim.record.McapRecorder.write_helm_decision` for the fields)."""
    decided = [None if x is None else float(x) for x in (heading_deg, speed, depth)]
    contrib = [(str(k), float(v)) for k, v in contributions.items()]
    tot = math.fsum(v for _, v in contrib) if total is None else float(total)
    values = [x for x in decided if x is not None] + [v for _, v in contrib]
    if not all(math.isfinite(x) for x in [*values, tot]):
        raise ConfigError("decision values and contributions must be finite", where=where)
    sec, nanosec = divmod(t_ns, 1_000_000_000)
    return cdr.encode_helm_decision(sec, nanosec, decided, str(mode), [str(a) for a in active],
                                    contrib, tot, str(all_stop_reason))


def variable_bytes(t_ns: int, name: str, value: float | str, source: str,
                   where: str) -> bytes:
    """A community variable posting as uhrisim_msgs/Variable: numbers (booleans as 0/1)
    in ``double_value`` with ``kind = DOUBLE``, strings in ``string_value`` (``STRING``)."""
    if isinstance(value, str):
        kind, dval, sval = 1, 0.0, value
    elif isinstance(value, float | numbers.Real):  # (a float answers without the ABC)
        kind, dval, sval = 0, float(value), ""
    else:
        raise ConfigError(f"variable {name!r} value must be a number or a string, got "
                          f"{type(value).__name__}", where=where)
    sec, nanosec = divmod(t_ns, 1_000_000_000)
    return cdr.encode_variable(sec, nanosec, str(name), str(source), kind, dval, sval)


def event_bytes(t_ns: int, frame_id: str, kind: str, detail: str) -> bytes:
    """Something that happened once (e.g. ``"collision"``) as uhrisim_msgs/Event."""
    sec, nanosec = divmod(t_ns, 1_000_000_000)
    return cdr.encode_event(sec, nanosec, frame_id, str(kind), str(detail))
