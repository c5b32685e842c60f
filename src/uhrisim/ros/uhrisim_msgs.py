"""uhrisim's own messages (``uhrisim_msgs``: HelmDecision, Variable, Event) serialised,
for the recorder and the live ROS 2 bridge alike.

Their definitions are :mod:`uhrisim.ros.msgdefs`' (embedded in every recording; the
live bridge builds the ROS 2 package from the same text,
:mod:`uhrisim.bridges.ros2.interfaces`); the bytes are CDR made by ``mcap_ros2``'s
schema-driven encoder. Each function checks its input and raises a ConfigError naming
``where``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping
from functools import cache
from typing import Any

from mcap_ros2._dynamic import serialize_dynamic

from uhrisim.core.errors import ConfigError
from uhrisim.ros.msgdefs import schema_text

HELM_DECISION = "uhrisim_msgs/msg/HelmDecision"
VARIABLE = "uhrisim_msgs/msg/Variable"
EVENT = "uhrisim_msgs/msg/Event"


@cache
def _encoder(typename: str) -> Any:
    return serialize_dynamic(typename, schema_text(typename))[typename]


def encode(typename: str, message: Mapping[str, Any]) -> bytes:
    """CDR of ``message`` (a dict of fields) as ``typename`` defined in msgdefs."""
    return _encoder(typename)(message)


def _header(t_ns: int, frame_id: str) -> dict[str, Any]:
    sec, nanosec = divmod(t_ns, 1_000_000_000)
    return {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": frame_id}


def helm_decision_bytes(t_ns: int, heading_deg: float | None, speed: float | None,
                        depth: float | None, contributions: Mapping[str, float], mode: str,
                        active: Iterable[str], total: float | None, all_stop_reason: str,
                        where: str) -> bytes:
    """One helm cycle as uhrisim_msgs/HelmDecision at ``t_ns`` (see
    :meth:`~uhrisim.record.McapRecorder.write_helm_decision` for the fields)."""
    decided = [None if x is None else float(x) for x in (heading_deg, speed, depth)]
    contrib = [{"name": str(k), "value": float(v)} for k, v in contributions.items()]
    tot = math.fsum(c["value"] for c in contrib) if total is None else float(total)
    values = [x for x in decided if x is not None] + [c["value"] for c in contrib]
    if not all(math.isfinite(x) for x in [*values, tot]):
        raise ConfigError("decision values and contributions must be finite", where=where)
    return encode(HELM_DECISION, {
        "header": _header(t_ns, ""),
        "has_heading": decided[0] is not None,
        "heading_deg": decided[0] or 0.0,
        "has_speed": decided[1] is not None,
        "speed": decided[1] or 0.0,
        "has_depth": decided[2] is not None,
        "depth": decided[2] or 0.0,
        "mode": str(mode),
        "active_behaviors": [str(a) for a in active],
        "contributions": contrib,
        "total": tot,
        "all_stop_reason": str(all_stop_reason),
    })


def variable_bytes(t_ns: int, name: str, value: float | str, source: str,
                   where: str) -> bytes:
    """A community variable posting as uhrisim_msgs/Variable: numbers (booleans as 0/1)
    in ``double_value`` with ``kind = DOUBLE``, strings in ``string_value`` (``STRING``)."""
    if isinstance(value, str):
        kind, dval, sval = 1, 0.0, value
    elif isinstance(value, numbers.Real):
        kind, dval, sval = 0, float(value), ""
    else:
        raise ConfigError(f"variable {name!r} value must be a number or a string, got "
                          f"{type(value).__name__}", where=where)
    return encode(VARIABLE, {"header": _header(t_ns, ""), "name": str(name),
                             "source": str(source), "kind": kind, "double_value": dval,
                             "string_value": sval})


def event_bytes(t_ns: int, frame_id: str, kind: str, detail: str) -> bytes:
    """Something that happened once (e.g. ``"collision"``) as uhrisim_msgs/Event."""
    return encode(EVENT, {"header": _header(t_ns, frame_id), "kind": str(kind),
                          "detail": str(detail)})
