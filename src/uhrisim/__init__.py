"""uhrisim: a Python simulator for underwater human-robot interaction.

Re-creates DeMarco, West & Howard, "A Simulator for Underwater Human-Robot
Interaction Scenarios" (OCEANS 2013). Units and frames: see docs/conventions.md.
"""

__version__ = "0.1.0"
