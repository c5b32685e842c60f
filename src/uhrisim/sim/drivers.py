"""What decides an agent's DESIRED_* each autonomy tick: its helm, or a script."""

from __future__ import annotations

from typing import TYPE_CHECKING

from uhrisim.autonomy.behaviors.base import OwnNav
from uhrisim.autonomy.contacts import ContactManager
from uhrisim.autonomy.helm import Helm
from uhrisim.core.frames import heading_deg_from_yaw, moos_xy_from_ned
from uhrisim.sim.community import Mailbox
from uhrisim.sim.hooks import HelmRecord
from uhrisim.sim.script import ScriptDriver

if TYPE_CHECKING:
    from uhrisim.sim.simulation import Agent


def own_nav(agent: Agent) -> OwnNav:
    nav = agent.nav()
    x_east, y_north = moos_xy_from_ned(nav.position_ned[0], nav.position_ned[1])
    return OwnNav(float(x_east), float(y_north), float(heading_deg_from_yaw(nav.yaw)),
                  nav.speed, float(nav.position_ned[2]))


class HelmDriver:
    """The behavior-fusion helm plus the agent's contact manager (pHelmIvP + contact mgr)."""

    def __init__(self, helm: Helm, contact_manager: ContactManager | None,
                 mailbox: Mailbox) -> None:
        self.helm = helm
        self.contact_manager = contact_manager
        self.mailbox = mailbox

    def tick(self, t: float, agent: Agent) -> HelmRecord:
        community = agent.community
        mail = self.mailbox.drain()
        if self.contact_manager is not None:
            reports = mail.get("NODE_REPORT", [])
            for var, value in self.contact_manager.step(t, own_nav(agent), reports):
                community.post(var, value, t, "contact_mgr")
            mail.update(self.mailbox.drain())  # alerts spawn behaviors in this same step
        out = self.helm.step(t, mail)
        for var, value in out.posts:
            community.post(var, value, t, "helm")
        decision = out.decision
        return HelmRecord(
            heading_deg=decision.heading_deg if decision else None,
            speed=decision.speed if decision else None,
            depth=decision.depth if decision else None,
            contributions=dict(out.contributions), total=out.total, mode=out.mode,
            active=tuple(out.active), all_stop_reason=out.all_stop_reason)


class ScriptedDriver:
    """Posts DESIRED_* from a timed script (:class:`~uhrisim.sim.script.ScriptDriver`)."""

    def __init__(self, script: ScriptDriver) -> None:
        self.script = script

    def tick(self, t: float, agent: Agent) -> None:
        desired = self.script.desired(t, agent.nav())
        if desired is None:
            return
        heading, speed, depth = desired
        agent.community.post("DESIRED_HEADING", heading, t, "script")
        agent.community.post("DESIRED_SPEED", speed, t, "script")
        if depth is not None:
            agent.community.post("DESIRED_DEPTH", depth, t, "script")
