"""What the viewer shows of a team mission (the frame's ``team`` entry, docs/viewer.md).

``team`` holds, in NED metres:

* ``objects``: every tool and load, ``{"name", "kind" (a tool kind or "load"),
  "north", "east", "depth", "held_by": [carrier, ...], "where"}``;
* ``sites``: every work site's state, ``{"name", "kind" ("flange", "hatch",
  "lift_bag", "load"), "north", "east", "depth", "text"}`` plus its numbers: a flange's
  ``bolts`` and ``bolts_out`` and ``cover_on``; a hatch's ``angle_deg`` and ``open``; a
  lift bag's ``litres`` (gas, surface litres) of ``capacity_litres`` and the load it is
  ``attached_to``; a load's ``height_m`` above where it started;
* ``progress``: per diver with orders, ``{"done", "total", "current" (text or None),
  "failed"}``;
* ``figures``: per articulated diver, its posed skeleton as a stick figure:
  ``{"points": [[north, east, depth], ...], "bones": [[i, j], ...]}`` (joint pivots,
  the head, the hands' grip points and the soles);
* ``log``: the last few teamwork and order events, ``[{"t", "kind", "text"}]``.

Live, :class:`TeamView` reads the simulation's teamwork stage
(``uhrisim.sim.teamwork.TeamStage``) by duck typing; a replay builds the same entry from
the recording's joint states, events and tools' ``/tf`` frames
(``uhrisim.viz.viewer.replay``), with the site entries made by the same functions.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uhrisim.teamwork.orders import describe

#: Events kept for the panel's log.
LOG_LENGTH = 6


def figure_points(skeleton: Any, q: ArrayLike, position_ned: ArrayLike,
                  rotation: ArrayLike) -> dict[str, list[Any]]:
    """The stick figure of a ``DiverSkeleton`` at joint angles ``q`` (rad), its body frame
    at ``position_ned`` (m) turned by ``rotation`` (3x3 body→NED): joint pivots joined to
    their parents, a head above the neck, grip points past the wrists and soles below
    the ankles. Points NED (m, mm precision)."""
    transforms = skeleton.joint_transforms(np.asarray(q, dtype=float))
    joints = skeleton.joints
    index = {j.name: i for i, j in enumerate(joints)}
    pivots = np.array([j.pivot for j in joints], dtype=float)
    body_pts = [t[:3, :3] @ p + t[:3, 3] for t, p in zip(transforms, pivots, strict=True)]
    bones = [[index[j.parent], i] for i, j in enumerate(joints) if j.parent is not None]

    def extend(joint: str, rest_point: NDArray[np.float64]) -> None:
        t = transforms[index[joint]]
        body_pts.append(t[:3, :3] @ rest_point + t[:3, 3])
        bones.append([index[joint], len(body_pts) - 1])

    b = skeleton.body
    extend("neck_flex", np.array([0.0, 0.0, b.head_centre_z]))
    for side in ("left", "right"):
        extend(f"{side}_wrist", skeleton.grip_point_rest(side))
        ankle = pivots[index[f"{side}_ankle"]]
        extend(f"{side}_ankle", np.array([b.foot_length - 0.05, ankle[1], b.hip_height]))
    world = np.asarray(body_pts) @ np.asarray(rotation, dtype=float).T + np.asarray(
        position_ned, dtype=float)
    return {"points": np.round(world, 3).tolist(), "bones": bones}


def _site(name: str, kind: str, position: ArrayLike, text: str, **numbers: Any
          ) -> dict[str, Any]:
    n, e, d = (float(v) for v in np.asarray(position, dtype=float)[:3])
    return {"name": name, "kind": kind, "north": n, "east": e, "depth": d, "text": text,
            **numbers}


def flange_site(name: str, position: ArrayLike, bolts: int, bolts_out: int,
                cover_on: bool) -> dict[str, Any]:
    """A flange's site entry: ``"2/4 bolts out"``, ``", cover off"`` once it is off."""
    text = f"{bolts_out}/{bolts} bolts out" + ("" if cover_on else ", cover off")
    return _site(name, "flange", position, text, bolts=bolts, bolts_out=bolts_out,
                 cover_on=bool(cover_on))


def hatch_site(name: str, position: ArrayLike, text: str, angle_deg: float,
               is_open: bool) -> dict[str, Any]:
    """A hatch's site entry: ``text`` (open, opening, closing, closed), the lid's angle."""
    return _site(name, "hatch", position, text, angle_deg=round(angle_deg, 1), open=is_open)


def bag_site(name: str, position: ArrayLike, litres: float | None, capacity: float,
             attached_to: str | None, state: str = "") -> dict[str, Any]:
    """A lift bag's site entry: its gas (surface litres) of its capacity, or ``state``
    (inflating, full, ...) when the gas is not known (None), and the load it is on."""
    fast = f" on {attached_to}" if attached_to else ""
    amount = f"{litres:.0f}/{capacity:.0f} L" if litres is not None else state
    return _site(name, "lift_bag", position, f"{amount}{fast}".strip(),
                 litres=None if litres is None else round(float(litres), 2),
                 capacity_litres=float(capacity), attached_to=attached_to)


def load_site(name: str, position: ArrayLike, height: float) -> dict[str, Any]:
    """A load's site entry: how far (m) it has risen from where it started."""
    return _site(name, "load", position, f"raised {height:.2f} m", height_m=round(height, 3))


class TeamView:
    """Builds the ``team`` entry from a live teamwork stage (module docstring)."""

    def __init__(self, team: Any) -> None:
        self.team = team
        ws = team.workspace
        self._start_depth = {name: float(ws.things[name].position[2]) for name in ws.loads
                             if name in ws.things}
        self._log: deque[dict[str, Any]] = deque(maxlen=LOG_LENGTH)

    def observe(self, events: Any) -> None:
        """Note a tick's simulation events (``teamwork`` and ``order`` ones go to the
        log)."""
        for ev in events:
            if ev.kind in ("teamwork", "order"):
                self._log.append({"t": round(float(ev.t), 2), "kind": ev.kind,
                                  "text": str(ev.detail)})

    def entry(self) -> dict[str, Any]:
        """The ``team`` entry now."""
        team = self.team
        ws = team.workspace
        objects = []
        for name, thing in ws.things.items():
            n, e, d = (float(v) for v in thing.position)
            kind = ws.tools[name].kind if name in ws.tools else "load"
            objects.append({"name": name, "kind": kind, "north": n, "east": e, "depth": d,
                            "held_by": list(ws.holders_of(name)), "where": str(thing.where)})
        sites = []
        for name, spec in ws.flanges.items():
            st = ws.flange_states[name]
            sites.append(flange_site(name, spec.position_ned, spec.n_bolts, sum(st.removed),
                                     st.cover_on))
        for name, spec in ws.hatches.items():
            st = ws.hatch_states[name]
            is_open = st.angle >= 0.5 * spec.open_angle
            text = "open" if is_open else ("opening" if st.opening else "closed")
            sites.append(hatch_site(name, spec.position_ned, text, math.degrees(st.angle),
                                    is_open))
        for name, spec in ws.bags.items():
            st = ws.bag_states[name]
            where = ws.things[name].position if name in ws.things else (0.0, 0.0, 0.0)
            sites.append(bag_site(name, where, st.gas_surface_litres, spec.capacity_litres,
                                  st.attached_to))
        for name, depth0 in self._start_depth.items():
            where = ws.things[name].position
            sites.append(load_site(name, where, depth0 - float(where[2])))
        progress, figures = {}, {}
        for name, body in team.divers.items():
            ex = body.executor
            if ex is not None:
                done = sum(s.outcome == "done" and not s.fetched for s in ex.steps)
                current = ex.current
                progress[name] = {"done": done, "total": len(ex.orders),
                                  "current": None if current is None else describe(current),
                                  "failed": bool(ex.failed)}
            position, rotation = team.body_pose(name)
            figures[name] = figure_points(body.skeleton, body.q, position, rotation)
        return {"objects": objects, "sites": sites, "progress": progress,
                "figures": figures, "log": list(self._log)}

