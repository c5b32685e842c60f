"""Integrators that know no physics: fixed-step RK4 with sub-stepping, and an adaptive
SciPy path. Models are pure ``f(t, x, u, params) -> dx/dt``; inputs are held constant
over a step (zero-order hold, as a digital controller does).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uhrisim.core.errors import ConfigError, NumericalError

Derivative = Callable[[float, NDArray[np.float64], NDArray[np.float64], Any], NDArray[np.float64]]

# Classical RK4 is stable on the negative real axis for |lambda dt| <= 2.785; we keep a
# margin. The stiffest rate is itself a worst case (full differential thrust at the top
# yaw rate), so 0.75 of the limit still leaves room.
RK4_REAL_AXIS_LIMIT = 2.785
STABILITY_MARGIN = 0.75
#: More sub-steps than this per physics step is refused: the model is too stiff for the
#: step (a default VideoRay needs 3 at 60 Hz; 100 keeps a simulated second well under a
#: second of CPU), so a run does not silently crawl.
MAX_SUBSTEPS = 100


def rk4_step(f: Derivative, t: float, x: NDArray, u: NDArray, params: Any, dt: float) -> NDArray:
    """One classical Runge-Kutta 4 step of size ``dt`` with ``u`` held constant."""
    k1 = f(t, x, u, params)
    k2 = f(t + 0.5 * dt, x + 0.5 * dt * k1, u, params)
    k3 = f(t + 0.5 * dt, x + 0.5 * dt * k2, u, params)
    k4 = f(t + dt, x + dt * k3, u, params)
    return x + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)


def substeps_for(dt: float, stiffest_rate: float | None) -> int:
    """Number of RK4 sub-steps that keeps ``|lambda| * h`` inside the stability margin."""
    if not dt > 0.0 or not math.isfinite(dt):
        raise ConfigError(f"physics step must be a positive number of seconds, got {dt}")
    if not stiffest_rate:
        return 1
    h_max = STABILITY_MARGIN * RK4_REAL_AXIS_LIMIT / stiffest_rate
    return max(1, math.ceil(dt / h_max - 1e-12))


@dataclass(frozen=True)
class FixedStepIntegrator:
    """RK4 over a step ``dt`` split into ``substeps`` equal sub-steps.

    Build it with :meth:`for_model` to pick the sub-step count from the model's stiffest
    eigenvalue; asking for fewer sub-steps than stability needs raises ``ConfigError``
    instead of silently exploding (the VideoRay yaw mode with J = 0.0118 has
    |lambda| ~ 320 1/s, so RK4 needs h <~ 4 ms).
    """

    f: Derivative
    dt: float
    substeps: int = 1
    name: str = "vehicle"

    @classmethod
    def for_model(cls, f: Derivative, dt: float, stiffest_rate: float | None,
                  substeps: int | None = None, name: str = "vehicle") -> FixedStepIntegrator:
        needed = substeps_for(dt, stiffest_rate)
        if needed > MAX_SUBSTEPS:
            raise ConfigError(
                f"{name} is too stiff for a {dt * 1e3:.2f} ms physics step: its fastest mode "
                f"({stiffest_rate:.0f} 1/s) needs {needed} RK4 sub-steps a step, more than "
                f"{MAX_SUBSTEPS}; check its inertia and gains, or raise physics_rate_hz",
                where=name,
            )
        if substeps is None:
            substeps = needed
        elif substeps < needed:
            h = dt / substeps
            raise ConfigError(
                f"RK4 sub-step {h * 1e3:.2f} ms is unstable for {name} (fastest mode "
                f"{stiffest_rate:.0f} 1/s); use substeps >= {needed} or a smaller step",
                where=f"{name}.substeps",
            )
        return cls(f=f, dt=dt, substeps=substeps, name=name)

    def step(self, t: float, x: NDArray, u: NDArray, params: Any) -> NDArray:
        """Advance ``x`` from ``t`` to ``t + dt``; raise ``NumericalError`` on NaN/inf."""
        h = self.dt / self.substeps
        with np.errstate(over="ignore", invalid="ignore"):  # reported below, by name
            for k in range(self.substeps):
                x = rk4_step(self.f, t + k * h, x, u, params, h)
        if not np.all(np.isfinite(x)):
            raise NumericalError("state became NaN/inf during integration",
                                 vehicle=self.name, t=t + self.dt)
        return x


def integrate_adaptive(f: Derivative, x0: NDArray, input_of_t: Callable[[float], NDArray],
                       params: Any, t_eval: NDArray, rtol: float = 1e-8, atol: float = 1e-10,
                       method: str = "LSODA", breakpoints: tuple[float, ...] = ()) -> NDArray:
    """Adaptive integration (SciPy; LSODA like Octave's ``lsode`` used by the authors).

    ``breakpoints`` are times where the input jumps; integration restarts there so the
    step-size control never straddles a discontinuity. Returns states at ``t_eval``.
    """
    from scipy.integrate import solve_ivp  # here: SciPy costs every importer ~0.3 s at start

    t_eval = np.asarray(t_eval, dtype=float)
    edges = [t_eval[0], *sorted(b for b in breakpoints if t_eval[0] < b < t_eval[-1]), t_eval[-1]]
    out = np.empty((t_eval.size, np.size(x0)))
    x = np.asarray(x0, dtype=float)
    for start, stop in itertools.pairwise(edges):
        wanted = t_eval[(t_eval >= start) & (t_eval <= stop)]
        times = np.union1d(wanted, [stop])
        u_segment = input_of_t(0.5 * (start + stop))
        sol = solve_ivp(lambda t, s, u=u_segment: f(t, s, u, params), (start, stop), x,
                        method=method, t_eval=times, rtol=rtol, atol=atol)
        if not sol.success:
            raise NumericalError(f"adaptive integration failed: {sol.message}", t=start)
        out[np.searchsorted(t_eval, wanted)] = sol.y.T[np.searchsorted(times, wanted)]
        x = sol.y[:, -1]
    return out
