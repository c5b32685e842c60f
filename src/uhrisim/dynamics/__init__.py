"""Vehicle and diver models as pure ``xdot(t, x, u, params)`` functions, plus integrators."""
