"""Problems a module has and cannot fix itself, told to the people who can.

A module that goes on doing what it can despite a problem (no sound device: it speaks silently;
a base that does not answer: it gives the trip up) says so with a :class:`ProblemReporter`. Each
change sends the module's open problems, each with its fix, on ``/cyborg_diagnostics/problems``
(``{"module", "open": [{"key", "problem", "fix"}]}`` as JSON in a latched ``std_msgs/String``, so
a dashboard started later still learns them). The dashboard shows every open one, the recorder
and the transcripts keep them, and the log has each once. Clearing one says it is over. Usable
from any module::

    self.problems = ProblemReporter(node)
    self.problems.report("the gripper does not answer", "check its cable", key="gripper")
    ...
    self.problems.clear("gripper")
"""

from __future__ import annotations

import json
import logging

from cyborg.transport import topics
from cyborg.transport.base import Node
from cyborg.transport.messages import String

__all__ = ["ProblemReporter"]

log = logging.getLogger(__name__)


class ProblemReporter:
    """Reports ``node``'s open problems, each under a ``key`` of its own (one per thing that can
    go wrong); a report repeated while open is sent once."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.open: dict[str, tuple[str, str]] = {}
        """The problems not over yet, by key: (problem, fix)."""
        self._publisher = node.publisher(topics.PROBLEMS, String, latch=True)

    def report(self, problem: str, fix: str = "", *, key: str = "") -> None:
        """Say that ``problem`` is there (``fix``: what a person can do about it)."""
        if self.open.get(key) == (problem, fix):
            return
        self.open[key] = (problem, fix)
        log.warning("%s: %s%s", self.node.name, problem, f"; fix: {fix}" if fix else "")
        self._send()

    def clear(self, key: str = "") -> None:
        """Say that the problem under ``key`` is over (nothing when none is open)."""
        if self.open.pop(key, None) is not None:
            log.info("%s: over: %s", self.node.name, key or "the problem")
            self._send()

    def _send(self) -> None:
        problems = [{"key": k, "problem": p, "fix": f} for k, (p, f) in sorted(self.open.items())]
        self._publisher.publish(String(json.dumps({"module": self.node.name, "open": problems})))
