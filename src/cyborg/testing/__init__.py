"""What a module author and the project's own tests drive a robot with, in virtual time.

- :class:`ModuleHarness` (:mod:`cyborg.testing.harness`): one behaviour module on its own, with
  probes for what it says, raises and feels, and drivers for goals, speech and emotion.
- :func:`wait_until` (:mod:`cyborg.testing.wait`): wait on a clock until something holds.
- :mod:`cyborg.testing.machines` and :mod:`cyborg.testing.idle_day`: generated state machines
  and an idle robot's day, the fixtures of tests and benchmarks.
"""

from cyborg.testing.harness import Feedback, Goal, GoalStatus, ModuleHarness
from cyborg.testing.wait import wait_until

__all__ = ["Feedback", "Goal", "GoalStatus", "ModuleHarness", "wait_until"]
