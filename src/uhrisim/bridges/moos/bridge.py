"""MOOS bridge for one simulated agent: posts what uSimMarine would, takes DESIRED_* back.

Frames and units at this edge (docs/conventions.md, docs/reference/helm.md):

============  =================================  =============================
MOOS var      meaning                            from the simulator (NED)
============  =================================  =============================
NAV_X         east of LatOrigin/LongOrigin, m    ``y_east``
NAV_Y         north of the origin, m             ``x_north``
NAV_DEPTH     depth, m, positive down            ``depth`` (NED z)
NAV_HEADING   compass degrees [0, 360)           ``heading_deg`` (wrapped)
NAV_SPEED     speed over ground, m/s             ``speed_mps``
NAV_LAT/LONG  degrees, CMOOSGeodesy local grid   from (east, north), see geodesy.py
NODE_REPORT   ``NAME=..,X=..,Y=..,SPD=..,HDG=..,DEP=..,LAT=..,LON=..,TYPE=..,MODE=..,
              TIME=..,LENGTH=..`` (pNodeReporter's keys)
============  =================================  =============================

Time stamps are MOOS time (see :mod:`uhrisim.bridges.moos.client`):
``time_source="moos"`` (default) stamps with the client's clock (wall clock x
MOOSTimeWarp), what a live MOOS community expects; ``time_source="sim"`` stamps with
``t0 + t_sim`` where ``t0`` is the MOOS time at bridge creation (deterministic offsets,
for a simulation that does not run in step with the wall clock).

Incoming: the bridge registers for ``subscribe`` (DESIRED_HEADING, DESIRED_SPEED,
DESIRED_DEPTH by default) and ``extra_vars``; :meth:`MoosAgentBridge.received` returns the
latest value and MOOS time of each. DESIRED_HEADING is compass degrees, DESIRED_SPEED m/s,
DESIRED_DEPTH m down - convert with ``uhrisim.core.frames`` (e.g.
``yaw_from_heading_deg``) on the simulator side.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping

from uhrisim.autonomy.contacts import node_report_text
from uhrisim.bridges.moos.client import MoosClient
from uhrisim.bridges.moos.geodesy import latlon_from_local
from uhrisim.core.errors import BridgeError
from uhrisim.core.frames import moos_xy_from_ned, wrap_360

__all__ = [
    "DEFAULT_LAT_ORIGIN",
    "DEFAULT_LONG_ORIGIN",
    "MoosAgentBridge",
]

log = logging.getLogger(__name__)

#: MIT Sailing Pavilion, the LatOrigin/LongOrigin of the MOOS-IvP example missions.
DEFAULT_LAT_ORIGIN = 42.358456
DEFAULT_LONG_ORIGIN = -71.087589

class MoosAgentBridge:
    """Connects one agent to a MOOS community, in place of uSimMarine.

    Parameters
    ----------
    agent_name:
        NODE_REPORT NAME (the vehicle name, e.g. ``videoray``).
    host, port:
        The MOOSDB (ServerHost/ServerPort of the ``.moos`` file).
    community:
        Expected MOOS community; a different one announced by the DB is logged as a
        warning (the bridge still works). ``None``: accept any.
    lat_origin, long_origin:
        LatOrigin/LongOrigin of the ``.moos`` file (degrees), for NAV_LAT/NAV_LONG.
    time_warp:
        MOOSTimeWarp of the community.
    subscribe, extra_vars:
        Variables to register for; :meth:`received` reports their latest values.
    client_name:
        MOOS process name (default ``uhrisim_<agent_name>``).
    node_report_var:
        ``NODE_REPORT`` (default; seen directly by a helm in the same community) or
        ``NODE_REPORT_LOCAL`` (pNodeReporter's name, when pShare forwards it).
    time_source:
        ``"moos"`` or ``"sim"``, see the module docstring.
    strict:
        Raise :class:`BridgeError` if the DB cannot be reached now; otherwise keep
        retrying in the background and log.
    client:
        An unconnected :class:`MoosClient` to use (tests); by default one is made.
    """

    def __init__(
        self,
        agent_name: str,
        host: str = "127.0.0.1",
        port: int = 9000,
        community: str | None = None,
        lat_origin: float = DEFAULT_LAT_ORIGIN,
        long_origin: float = DEFAULT_LONG_ORIGIN,
        time_warp: float = 1.0,
        subscribe: Iterable[str] = ("DESIRED_HEADING", "DESIRED_SPEED", "DESIRED_DEPTH"),
        extra_vars: Iterable[str] = (),
        *,
        client_name: str | None = None,
        node_report_var: str = "NODE_REPORT",
        time_source: str = "moos",
        strict: bool = False,
        connect_timeout_s: float = 3.0,
        client: MoosClient | None = None,
    ) -> None:
        if time_source not in ("moos", "sim"):
            raise BridgeError(f"MoosAgentBridge: time_source {time_source!r} not 'moos'/'sim'")
        if not (-90.0 < lat_origin < 90.0) or not (-180.0 <= long_origin <= 180.0):
            raise BridgeError(
                f"MoosAgentBridge: origin ({lat_origin}, {long_origin}) is not a lat/long")
        self.agent_name = agent_name
        self.community = community
        self.lat_origin = float(lat_origin)
        self.long_origin = float(long_origin)
        self.node_report_var = node_report_var
        self.time_source = time_source
        self.variables: tuple[str, ...] = tuple(dict.fromkeys((*subscribe, *extra_vars)))
        self._latest: dict[str, tuple[float | str | bytes, float]] = {}
        self._community_checked = False
        self.client = client if client is not None else MoosClient(time_warp=time_warp)
        self._t0 = self.client.moos_time()
        for v in self.variables:
            self.client.register(v, 0.0)
        self.client.connect(host, port, client_name or f"uhrisim_{agent_name}",
                            strict=strict, timeout_s=connect_timeout_s)

    # -- state ------------------------------------------------------------------------
    @property
    def connected(self) -> bool:
        return self.client.connected

    @property
    def status(self) -> str:
        return self.client.status

    def moos_time(self, t_sim: float | None = None) -> float:
        """The MOOS time stamp used for a post at simulation time ``t_sim`` (s)."""
        if self.time_source == "sim" and t_sim is not None:
            return self._t0 + float(t_sim)
        return self.client.moos_time()

    # -- outgoing -----------------------------------------------------------------------
    def publish_nav(
        self,
        t_sim: float,
        x_north: float,
        y_east: float,
        depth: float,
        heading_deg: float,
        speed_mps: float,
        vehicle_type: str = "UUV",
        length: float = 1.0,
        mode: str = "NONE",
    ) -> bool:
        """Post NAV_X/Y/DEPTH/HEADING/SPEED/LAT/LONG and the NODE_REPORT of one state.

        Inputs in the simulator's frame: NED north/east/depth (m), compass heading (deg,
        any range - wrapped to [0, 360)), speed (m/s). Returns True if sent now, False if
        the DB is unreachable (the latest values are then sent on reconnection).
        """
        vals = x_north, y_east, depth, heading_deg, speed_mps = (
            float(x_north), float(y_east), float(depth), float(heading_deg), float(speed_mps))
        if not all(math.isfinite(v) for v in vals):
            raise BridgeError(f"MOOS publish_nav({self.agent_name}): non-finite value {vals}")
        self._check_community()
        hdg = wrap_360(heading_deg)
        x_e, y_n = moos_xy_from_ned(x_north, y_east)  # MOOS: x east, y north
        lat, lon = latlon_from_local(x_e, y_n, self.lat_origin, self.long_origin)
        t = self.moos_time(t_sim)
        report = node_report_text(self.agent_name, x_e, y_n, speed_mps, hdg, depth, lat=lat,
                                  lon=lon, type=vehicle_type, mode=mode, time=t,
                                  length=length)
        return self.client.notify_many((
            ("NAV_X", x_e), ("NAV_Y", y_n), ("NAV_DEPTH", depth), ("NAV_HEADING", hdg),
            ("NAV_SPEED", speed_mps), ("NAV_LAT", lat), ("NAV_LONG", lon),
            (self.node_report_var, report)), t)

    def publish_var(self, name: str, value: float | str | bytes, t_sim: float | None = None
                    ) -> bool:
        """Post any variable (a double, a string, or binary bytes)."""
        return self.client.notify(name, value, self.moos_time(t_sim))

    # -- incoming -----------------------------------------------------------------------
    def received(self) -> Mapping[str, tuple[float | str | bytes, float]]:
        """Latest ``{var: (value, moos_time)}`` of every subscribed variable heard so far.

        Non-blocking: takes whatever the client thread has collected since the last call.
        """
        self.poll()
        return dict(self._latest)

    def poll(self) -> list[tuple[str, float | str | bytes, float]]:
        """New ``(var, value, moos_time)`` arrivals since the last call, oldest first
        (also folded into :meth:`received`). Non-blocking."""
        new = [(m.key, m.value, m.time) for m in self.client.drain()]
        for key, value, t in new:
            self._latest[key] = (value, t)
        return new

    def desired(self) -> tuple[float | None, float | None, float | None]:
        """(DESIRED_HEADING deg, DESIRED_SPEED m/s, DESIRED_DEPTH m), None where unheard."""
        r = self.received()

        def num(k: str) -> float | None:
            v = r.get(k)
            return float(v[0]) if v is not None and isinstance(v[0], float) else None

        return num("DESIRED_HEADING"), num("DESIRED_SPEED"), num("DESIRED_DEPTH")

    def close(self) -> None:
        self.client.close()

    def __enter__(self) -> MoosAgentBridge:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _check_community(self) -> None:
        if self._community_checked or self.client.community is None:
            return
        self._community_checked = True
        if self.community is not None and self.client.community != self.community:
            log.warning("MOOS bridge %r: DB community is %r, expected %r", self.agent_name,
                        self.client.community, self.community)
