"""Behaviour controller for the NTNU Cyborg social robot.

The composition root :mod:`cyborg.app` builds the robot from its configuration; a module
author needs :mod:`cyborg.modules` and :mod:`cyborg.testing`. The layers, and the one way
imports flow through them, are in ``docs/architecture.md`` (``tests/test_layers.py``
enforces them).
"""

__version__ = "0.1.0"
