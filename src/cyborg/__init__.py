"""Behaviour controller for the NTNU Cyborg social robot.

Layers (imports flow one way): ``cyborg.transport`` -> ``cyborg.controller``
(state machine, emotion system, motivator) -> ``cyborg.modules`` /
``cyborg.navigation`` -> ``cyborg.sim`` -> ``cyborg.interfaces`` (CLI, dashboard).
"""

__version__ = "0.1.0"
