"""The application above the loop and its outputs: a run end to end and what it reports.

:func:`~uhrisim.app.runner.run_scenario` builds a :class:`~uhrisim.sim.simulation.Simulation`,
attaches the recording (:mod:`uhrisim.record`), the mission and perception metrics
(:mod:`.metrics`, :mod:`.perception_metrics`) and the live outputs it is given, runs it, and
writes ``metrics.json`` and the figures (drawn by :mod:`uhrisim.viz`). The loop (``sim/``)
knows nothing of recordings, figures or bridges; this layer, above them all, joins them.
"""
