"""Simulation only: a simulated robot base, its route planning, and scenario scripts and runs.

:mod:`~cyborg.sim.base` stands in for the Pioneer LX and ROSARNL (or nav2);
:mod:`~cyborg.sim.planner` plans its routes on the map, with the A* search in
:mod:`~cyborg.sim.grid_search`, searched ahead on a second process by
:mod:`~cyborg.sim.search_ahead` (whose worker is :mod:`~cyborg.sim._search_worker`).
:mod:`~cyborg.sim.script` reads scenario scripts and :mod:`~cyborg.sim.scenario` runs them,
writing transcripts with :mod:`~cyborg.sim.transcript`;
:mod:`~cyborg.sim.witness` tells a failed step what dropped or broke what it waited for;
:mod:`~cyborg.sim.rerun` re-runs a recording from its recorded inputs (``cyborg rerun``), and
:mod:`~cyborg.sim.rerun_controller` the controller alone against a launch's real-time recording.
"""
