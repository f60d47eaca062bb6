"""The controller's state machine: its specification, its configuration and its runtime.

:mod:`~cyborg.controller.machine` is the machine as data (states, superstates, transitions;
pure), :mod:`~cyborg.controller.regions` how parallel states' regions step and share resources
(pure), :mod:`~cyborg.controller.clashes` the static check that two regions never hold an
exclusive resource at once (pure), :mod:`~cyborg.controller.config` its YAML schema, and
:mod:`~cyborg.controller.runtime` the controller that hands control from module to module over
actions, its events waiting in :mod:`~cyborg.controller.intake` (bounded by size and age,
fair to senders). Drawing it is
:mod:`cyborg.drawing`'s.
"""
