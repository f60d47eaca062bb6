"""Behaviour controller for the NTNU Cyborg social robot.

The composition root :mod:`cyborg.app` builds the robot from its configuration; a module
author needs :mod:`cyborg.modules` and :mod:`cyborg.testing`. The layers, and the one way
imports flow through them, are in ``docs/architecture.md`` (``tests/test_layers.py``
enforces them).
"""

from cyborg.__version__ import __version__

__all__ = ["__version__"]
