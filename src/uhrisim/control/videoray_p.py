"""The paper's proportional depth/heading/speed controller with weighted mixing (eqs 5-9).

    e_h = wrap_180(desired_heading - heading)        (degrees, the short way round)
    e_s = desired_speed - u                          (m/s, surge)
    u_port = w_h ( K_h e_h) + w_s K_s e_s + ff
    u_star = w_h (-K_h e_h) + w_s K_s e_s + ff
    u_vert = -K_d (desired_depth - depth) + ff_load  (a depth deficit dives)

all saturated at +-150. A positive heading error (target clockwise of the bow) needs
more port thrust (docs/conventions.md). ``ff`` is an optional speed feed-forward: the
thruster input whose thrust balances the drag at the desired speed. The paper's
controller has none (``speed_feedforward=False``); without it a P speed loop settles
well below the target against the VideoRay's drag. ``ff_load`` is an optional load
feed-forward, not in the paper either: the vertical input whose thrust carries the
in-water weight of what the gripper holds (``held_load_input``; the assistant's ROV knows
what it holds, :meth:`VideoRayPController.holding`; without it the P depth loop would
settle W / (K_d c_T) low under a load, 2.3 m under the 3.1 N lift bag at K_d 50 with the
linear map). It is zero, and the paper's controller unchanged, while nothing is held.
Holding a load, ``ff`` balances the loaded vehicle's drag (``params`` are then the loaded
ones), so the ROV makes the speed it is ordered to: with the empty vehicle's drag it made
0.114 m/s of a 0.2 m/s order, carrying the lift bag.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.elementwise import ARRAYS, FLOATS, Elementwise
from uhrisim.core.frames import heading_deg_from_yaw, wrap_180
from uhrisim.core.settings import check_settings, setting
from uhrisim.dynamics.carried_load import CarriedLoad, hover_command, loaded_params
from uhrisim.dynamics.videoray import VideoRayParams, linear_thrust


@dataclass(frozen=True)
class PGains:
    """Proportional gains: K_h per degree, K_s per m/s, K_d per metre; mixing weights."""

    heading: float = setting(1.0, "1/deg", ge=0.0, le=1e4,
                             doc="K_h: thruster input per degree of heading error")
    speed: float = setting(10.0, "s/m", ge=0.0, le=1e4,
                           doc="K_s: thruster input per m/s of speed error")
    depth: float = setting(50.0, "1/m", ge=0.0, le=1e4,
                           doc="K_d: thruster input per metre of depth error")
    heading_weight: float = setting(0.5, "1", ge=0.0, le=100.0, doc="w_h, heading mixing")
    speed_weight: float = setting(0.5, "1", ge=0.0, le=100.0, doc="w_s, speed mixing")
    speed_feedforward: bool = False

    def __post_init__(self) -> None:
        check_settings(self)


# Gains found in the authors' code (docs/reference/vehicles-and-control.md): the ROS control
# node (K_h 1, the value it actually ran with; an earlier revision had 0.01), and the Octave
# simulation.
GAIN_PRESETS: dict[str, PGains] = {
    "ros-node": PGains(heading=1.0, speed=10.0, depth=50.0),
    "ros-node-early": PGains(heading=0.01, speed=10.0, depth=50.0),
    "octave": PGains(heading=100.0, speed=100.0, depth=100.0),
    # Not from the paper: ros-node gains plus drag feed-forward, used by the mission so the
    # ROV can keep up with a swimming diver.
    "mission": PGains(heading=2.0, speed=40.0, depth=50.0, speed_feedforward=True),
}


def feedforward_input(speed: Any, params: VideoRayParams, ops: Elementwise = FLOATS) -> Any:
    """Per-thruster input whose two-thruster thrust balances surge drag at ``speed`` (m/s;
    a float, or an (N,) array with ``ops`` :data:`~uhrisim.core.elementwise.ARRAYS`)."""
    drag = -(params.Xu * speed + params.Xuu * abs(speed) * speed)
    per_thruster = 0.5 * drag
    if linear_thrust(params):
        return per_thruster / params.ct_linear
    ct = ops.where(per_thruster >= 0, params.ct_forward_quadratic, params.ct_reverse_quadratic)
    return ops.copysign(ops.sqrt(abs(per_thruster) / ct), per_thruster)


@dataclass(frozen=True)
class VideoRayPController:
    """Stateless controller: ``inputs(x, desired) -> [port, star, vert]`` for one vehicle,
    :meth:`inputs_many` for N; both run :meth:`kernel`."""

    gains: PGains
    params: VideoRayParams
    #: ``ff_load``: the vertical input that holds what the gripper holds at depth
    #: (:func:`uhrisim.dynamics.carried_load.hover_command`; module docstring); 0 leaves
    #: the paper's controller as it is
    held_load_input: float = 0.0

    def holding(self, vehicle: VideoRayParams, load: CarriedLoad | None
                ) -> VideoRayPController:
        """This controller for ``vehicle`` (the empty vehicle's parameters) with ``load`` in
        its gripper (None: nothing): the load's in-water weight fed forward in depth, the
        loaded vehicle's drag in the speed feed-forward (module docstring)."""
        if load is None:
            return replace(self, params=vehicle, held_load_input=0.0)
        return replace(self, params=loaded_params(vehicle, load),
                       held_load_input=hover_command(vehicle, load).command)

    def inputs(self, x: NDArray, desired_heading_deg: float, desired_speed: float,
               desired_depth: float) -> NDArray:
        _, _, depth, yaw, surge = np.asarray(x[:5], dtype=float).tolist()
        return np.array(self.kernel(depth, yaw, surge, float(desired_heading_deg),
                                    float(desired_speed), float(desired_depth)))

    def inputs_many(self, x: NDArray, desired_heading_deg: NDArray, desired_speed: NDArray,
                    desired_depth: NDArray) -> NDArray:
        """Inputs (N, 3) of N vehicles: states ``x`` (N, 8), desired values (N,) each."""
        x = np.asarray(x, dtype=float)
        return np.stack(self.kernel(x[:, 2], x[:, 3], x[:, 4], np.asarray(desired_heading_deg,
                                    dtype=float), np.asarray(desired_speed, dtype=float),
                                    np.asarray(desired_depth, dtype=float), ARRAYS), axis=-1)

    def kernel(self, depth: Any, yaw: Any, surge: Any, desired_heading_deg: Any,
               desired_speed: Any, desired_depth: Any, ops: Elementwise = FLOATS
               ) -> tuple[Any, Any, Any]:
        """Eqs 5-9 on floats (one vehicle) or (N,) arrays (``ops``): (port, star, vert)."""
        return p_control_kernel(self.gains, self.params, depth, yaw, surge,
                                desired_heading_deg, desired_speed, desired_depth, ops,
                                self.held_load_input)


def p_control_kernel(g: PGains, params: VideoRayParams, depth: Any, yaw: Any, surge: Any,
                     desired_heading_deg: Any, desired_speed: Any, desired_depth: Any,
                     ops: Elementwise, held_load_input: float = 0.0) -> tuple[Any, Any, Any]:
    """:meth:`VideoRayPController.kernel` with its gains and parameters as arguments (a
    function numba can compile, given them as records: :func:`uhrisim.core.compiled.record`);
    ``held_load_input``: the vertical input fed forward for a held load (0: the paper's)."""
    heading_error = wrap_180(desired_heading_deg - heading_deg_from_yaw(yaw))
    speed_term = g.speed_weight * g.speed * (desired_speed - surge)
    if g.speed_feedforward:
        speed_term = speed_term + feedforward_input(desired_speed, params, ops)
    heading_term = g.heading_weight * g.heading * heading_error
    port = heading_term + speed_term
    star = -heading_term + speed_term
    vert = -g.depth * (desired_depth - depth)
    if held_load_input:
        vert = vert + held_load_input
    limit = params.input_limit
    return (ops.clip(port, -limit, limit), ops.clip(star, -limit, limit),
            ops.clip(vert, -limit, limit))
