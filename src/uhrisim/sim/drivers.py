"""What decides an agent's DESIRED_* each autonomy tick: its helm, or a script."""

from __future__ import annotations

from uhrisim.autonomy.behaviors.base import OwnNav
from uhrisim.autonomy.community import VehicleAutonomy
from uhrisim.sim.community import Mailbox
from uhrisim.sim.hooks import HelmRecord
from uhrisim.sim.script import ScriptDriver
from uhrisim.sim.state import Agent


class HelmDriver:
    """The agent's contact manager + behavior-fusion helm (pBasicContactMgr + pHelmIvP)."""

    def __init__(self, autonomy: VehicleAutonomy, mailbox: Mailbox) -> None:
        self.autonomy = autonomy
        self.mailbox = mailbox

    def tick(self, t: float, agent: Agent) -> HelmRecord:
        community = agent.community
        mail = self.mailbox.drain()
        reports = mail.pop("NODE_REPORT", [])
        nav = agent.nav()
        own = OwnNav.from_ned(*nav.position_ned, nav.yaw, nav.speed)
        out = self.autonomy.step(t, own, reports, extra_mail=mail)
        community.post_many(self.autonomy.last_contact_posts, t, "contact_mgr")
        community.post_many(out.posts, t, "helm")
        self.mailbox.drain()  # our own posts: the helm already applied them
        decision = out.decision
        return HelmRecord(
            heading_deg=decision.heading_deg if decision else None,
            speed=decision.speed if decision else None,
            depth=decision.depth if decision else None,
            contributions=out.contributions,  # the helm's own copy, new each tick
            total=out.total, mode=out.mode,
            active=out.active, all_stop_reason=out.all_stop_reason)


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
