"""The robot's calendar as the rest of the robot sees it: an entry, and the component that keeps them.

A scenario script's ``calendar:`` entries (:mod:`cyborg.sim.script`) are added, before the run
starts, to the component of the robot that keeps a calendar: the navigation module, which then
plans a trip to each entry's place when it begins. :func:`cyborg.app.context.calendar_of` finds that
component; how recurrences are expanded is in :mod:`cyborg.navigation.recurrence`, and how
``.ics`` files are imported in :mod:`cyborg.navigation.ics`.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

__all__ = ["CalendarEntry", "KeepsCalendar"]


class CalendarEntry(Protocol):
    """A calendar entry a scenario script adds: be at ``location`` from ``start`` to ``end``.

    ``recurrence`` is an RFC 5545 rule (or None for once); ``ignore`` marks an entry the robot
    is to skip.
    """

    location: str
    start: Any
    end: Any
    ignore: bool
    recurrence: Any


@runtime_checkable
class KeepsCalendar(Protocol):
    """A component with a calendar that scenario scripts can add entries to (the navigation module)."""

    def add_calendar_entry(self, entry: CalendarEntry) -> None: ...
