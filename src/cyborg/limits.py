"""Limits on everything a user or a file can hand the robot.

A small input must not take unbounded memory or time: a 600-byte YAML alias bomb, a
megabyte of "speech", a map header promising a gigapixel image or a calendar rule that
repeats every second since 1970. Each limit lives here, so the refusals, the checks and
docs/configuration.md name the same numbers. Every refusal names the limit and the fix.
"""

from __future__ import annotations

MAX_YAML_BYTES = 1_000_000
"""Largest state machine file or scenario script. The packaged Cyborg is about 8 kB."""

MAX_YAML_NODES = 200_000
"""Most values a YAML file may hold once its aliases (``*name``) are expanded."""

MAX_YAML_DEPTH = 64
"""Deepest nesting of mappings and lists in a YAML file."""

MAX_TEXT_LENGTH = 2_000
"""Longest text the robot is told to have heard (a scenario's ``say``, the API's /api/say)."""

MAX_SCRIPT_SECONDS = 366 * 24 * 3600.0
"""Longest virtual time a scenario script may run (``until``, ``at``, ``delay``): a year."""

MAX_SPEED = 1e6
"""Largest virtual-time factor for ``--speed`` (use ``max`` for as fast as possible)."""

MIN_SPEED = 0.01
"""Smallest virtual-time factor for ``--speed``: a virtual second every 100 real ones (1e-9 overflowed
the clock's waits; 1e-6 made a virtual second last 11.6 days)."""

MAX_MAP_CELLS = 25_000_000
"""Most grid cells of a map (5000 x 5000, e.g. 250 m x 250 m at 5 cm): about 25 MB of grid."""

MAX_ICS_BYTES = 10_000_000
"""Largest .ics calendar file ``cyborg db import-ics`` reads."""

MAX_RULE_COUNT = 10_000
"""Largest COUNT of a calendar rule (a daily event for 27 years); longer series use UNTIL."""

MAX_EVENT_DAYS = 366
"""Longest calendar event (one occurrence), in days."""

MAX_OCCURRENCES_PER_QUERY = 1_000
"""Most occurrences of one recurring event that one calendar query expands."""

MAX_RULE_STEPS = 200_000
"""Most steps (periods of its FREQ that dateutil looks at) a calendar rule may take from one occurrence
to the next."""

MAX_RULE_SECONDS = 0.5
"""Most CPU time a calendar rule may take from one occurrence to the next (a sparse FREQ=SECONDLY rule
steps through every day of the years between its occurrences)."""

MAX_RULE_TOTAL_SECONDS = 1.0
"""Most CPU time one expansion of a calendar rule (a check, a query) may take in all."""
