"""What the navigation module watches while the base drives a person somewhere: pure logic, no I/O.

A real base can fail quietly: its node hangs and never accepts the goal, or its localisation
stops and the pose topic goes silent while the wheels turn. :class:`TripWatch` is told when the
trip started, when the goal was last seen pending and when the last pose came, and says what is
wrong (a sentence naming the fix) once a limit is passed; the module then gives the trip up.
Each limit is off when it is ``None`` (the simulated base never fails this way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["TripWatch"]


@dataclass
class TripWatch:
    """Limits for one trip: ``answer_timeout`` s for the base to accept the goal, ``pose_timeout``
    s of silence on the pose topic while the goal is active."""

    base: str
    """The base's action (named in the problems)."""
    pose_topic: str
    started: float
    answer_timeout: float | None = None
    pose_timeout: float | None = None
    accepted_at: float | None = None

    @property
    def watching(self) -> bool:
        return self.answer_timeout is not None or self.pose_timeout is not None

    def step(self, feedback_interval: float) -> float:
        """Seconds between looks: often enough to notice either limit within a quarter of it."""
        limits = [t for t in (self.answer_timeout, self.pose_timeout) if t is not None]
        return min([feedback_interval, *(t / 4 for t in limits)])

    def problem(self, now: float, accepted: bool, last_pose: float) -> str | None:
        """What is wrong at ``now`` (None: nothing yet). ``accepted``: the base has taken the goal;
        ``last_pose``: when the last pose came (``-inf``: none yet)."""
        if not accepted:
            if self.answer_timeout is not None and now - self.started >= self.answer_timeout:
                return (
                    f"the robot base has not answered the goal on {self.base} for "
                    f"{now - self.started:.0f} s; fix: check that the base's node runs and answers "
                    "(cyborg doctor), then ask again"
                )
            return None
        if self.accepted_at is None:
            self.accepted_at = now
        if self.pose_timeout is None:
            return None
        since = max(self.accepted_at, last_pose if math.isfinite(last_pose) else -math.inf)
        if now - since >= self.pose_timeout:
            return (
                f"the base's pose on {self.pose_topic} has been silent for {now - since:.0f} s while "
                "driving, so the robot cannot tell where it is and has stopped; fix: check the "
                "base's localisation (its node and its laser), then ask again"
            )
        return None
