"""Hooks that connect a run to the outside world: ROS 2, MOOS-IvP, wall-clock pacing.

Built from the scenario's ``bridges`` section; the command line can switch a bridge on
(``--ros2``, ``--moos``) without editing the file. An agent that an outside planner
drives should have ``driver: external`` (or ``none``), or its own helm will keep
overwriting the DESIRED_* the bridge delivers.
"""

from __future__ import annotations

import logging

from uhrisim.scenario.schema import HelmWatchSection, Scenario
from uhrisim.sim.pacing import PacingHook
from uhrisim.sim.simulation import Hook

log = logging.getLogger(__name__)


def ros2_hook(scenario: Scenario, lockstep: bool = False,
              ros_args: tuple[str, ...] = (), require_helm: bool = False) -> Hook:
    """The ROS 2 hook of the scenario's ``bridges.ros2`` section; ``lockstep`` switches
    lockstep on whatever the section says; ``ros_args`` come after the section's;
    ``require_helm``: see :func:`live_hooks`."""
    from uhrisim.bridges.ros2 import Ros2BridgeHook

    section = scenario.bridges.ros2
    links = section.links
    agents = [link.agent for link in links] if links else None
    accept = ({link.agent: link.accept for link in links} if links
              else ("desired", "thrusters"))  # links: each its own; else divers none
    return Ros2BridgeHook(agents, accept=accept, odom_rate_hz=section.odom_rate_hz,
                          domain_id=section.domain_id,
                          command_timeout_s=section.command_timeout_s,
                          lockstep=lockstep or section.lockstep,
                          lockstep_timeout_s=section.lockstep_timeout_s,
                          node_name=section.node_name, namespace=section.namespace,
                          ros_args=(*section.ros_args, *ros_args),
                          helm_watch=helm_watch(scenario, require_helm))


def helm_watch(scenario: Scenario, require_helm: bool) -> HelmWatchSection:
    """The scenario's ``bridges.helm_watch``, required when ``require_helm`` says so."""
    watch = scenario.bridges.helm_watch
    return watch.model_copy(update={"required": True}) if require_helm else watch


def moos_hook(scenario: Scenario, require_helm: bool = False) -> Hook:
    """The MOOS hook of the scenario's ``bridges.moos`` section (``require_helm``: see
    :func:`live_hooks`)."""
    from uhrisim.bridges.moos.hook import MoosAgentLink, MoosBridgeHook

    section = scenario.bridges.moos
    if section.links:
        links = [MoosAgentLink(agent=link.agent, port=link.port, host=link.host,
                               community=link.community, nav_rate_hz=link.nav_rate_hz,
                               subscribe=link.subscribe, extra_vars=link.extra_vars,
                               vehicle_type=link.vehicle_type,
                               node_report_var=link.node_report_var)
                 for link in section.links]
    else:
        links = [MoosAgentLink(agent=agent.name, port=9000 + index)
                 for index, agent in enumerate(scenario.agents)]
    for link in links:
        agent = next(a for a in scenario.agents if a.name == link.agent)
        if agent.driver == "helm" and set(link.subscribe) & {"DESIRED_HEADING", "DESIRED_SPEED"}:
            log.warning("agent %r has its own helm and also takes DESIRED_* from MOOS; its "
                        "helm will overwrite them (set driver: external)", agent.name)
    return MoosBridgeHook(links, lat_origin=scenario.lat_origin,
                          long_origin=scenario.long_origin, time_warp=section.time_warp,
                          helm_watch=helm_watch(scenario, require_helm))


def live_hooks(scenario: Scenario, *, ros2: bool = False, moos: bool = False,
               real_time_factor: float | None = None, paced_elsewhere: bool = False,
               lockstep: bool = False, ros_args: tuple[str, ...] = (),
               require_helm: bool = False, foxglove_port: int | None = None) -> list[Hook]:
    """The bridge hooks the scenario (or the command line) asks for, plus pacing.

    ``real_time_factor`` overrides the scenario's; with MOOS on, the default pace is its
    MOOSTimeWarp. ``paced_elsewhere``: the viewer paces the run itself. ``lockstep``
    switches the ROS 2 bridge on, in lockstep; ``ros_args`` go to its node.
    ``require_helm``: an agent's outside helm that does not drive ends the run as failed
    (``bridges.helm_watch.required``; :mod:`uhrisim.bridges.helm_watch`).
    ``foxglove_port``: serve the run live to Foxglove on 127.0.0.1 at this port
    (:mod:`uhrisim.bridges.foxglove`; paced at real time unless told otherwise).
    """
    bridges = scenario.bridges
    hooks: list[Hook] = []
    use_ros2 = ros2 or lockstep or bridges.ros2.enabled
    use_moos = moos or bridges.moos.enabled
    if use_ros2:
        hooks.append(ros2_hook(scenario, lockstep=lockstep, ros_args=ros_args,
                               require_helm=require_helm))
    if use_moos:
        hooks.append(moos_hook(scenario, require_helm))
    if foxglove_port is not None:
        from .foxglove import FoxgloveHook

        hooks.append(FoxgloveHook(port=foxglove_port))
    if (use_ros2 or use_moos or foxglove_port is not None) and not paced_elsewhere:
        factor = real_time_factor if real_time_factor is not None else (
            bridges.moos.time_warp if use_moos else bridges.real_time_factor or 1.0)
        if factor is not None and factor > 0:
            hooks.append(PacingHook(factor))
    return hooks
