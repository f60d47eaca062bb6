"""The one exception hierarchy of the project.

Every error names the bad value and says how to fix it, so a student who meets
it for the first time knows what to do next.
"""

from __future__ import annotations


class CyborgError(Exception):
    """Base class of every error raised by the cyborg package."""


class ConfigError(CyborgError):
    """A configuration file (state machine YAML, scenario script) is invalid.

    ``problems`` holds one line per problem; ``str()`` joins them.
    """

    def __init__(self, problems: list[str] | str, *, source: str | None = None) -> None:
        self.problems = [problems] if isinstance(problems, str) else list(problems)
        self.source = source
        prefix = f"{source}: " if source else ""
        super().__init__("\n".join(prefix + p for p in self.problems))


class TransportError(CyborgError):
    """Something went wrong in the message transport (topics, services, actions)."""


class ServiceTimeoutError(TransportError):
    """A service call got no answer within its timeout."""


class ServiceUnavailableError(TransportError):
    """A service call was made to a service nobody offers."""


class ModuleBlockedError(CyborgError):
    """Raised inside a module's callback or goal that held the in-process robot's event loop past
    one of the controller's handover deadlines: the loop watchdog stops the blocking call so the
    handover goes on (see :mod:`cyborg.transport.watchdog`)."""


class DatabaseError(CyborgError):
    """A database could not be opened, migrated or written."""


class MapError(CyborgError):
    """A map file could not be read, or a location is not on the map."""


class PlanningError(CyborgError):
    """No collision-free route exists between two poses."""


class NavigationError(CyborgError, ValueError):
    """A value given to the navigation module (a time, a match threshold) is unusable.

    Also a ValueError, which callers of the navigation package caught before this class existed.
    """


class CalendarError(NavigationError):
    """A calendar event, a time or a recurrence rule cannot be used; the message says which and the fix."""


class RuleTooCostly(CalendarError):
    """A recurrence rule that is valid RFC 5545 but would cost unbounded time, or repeats nothing."""


class InvalidValueError(CyborgError, ValueError):
    """A value (a setting, an argument, a time in a script) is out of range or malformed.

    The message names the value and the fix, as ``"what is wrong; fix: how"``. Also a
    ValueError: pydantic turns one raised in a validator into a validation error (which
    :func:`cyborg.configfile.describe_errors` words), and callers that caught ValueError
    before this class existed still catch it.
    """


class ScenarioFailed(CyborgError):
    """A scenario script ran, but an ``expect`` step was not met or a ``when`` never fired.

    ``problems`` holds one line per failed step: its line in the script, what it waited for
    and what happened instead.
    """

    def __init__(self, problems: list[str], *, source: str | None = None) -> None:
        self.problems = list(problems)
        self.source = source
        prefix = f"{source}: " if source else ""
        super().__init__("\n".join(prefix + p for p in self.problems))
