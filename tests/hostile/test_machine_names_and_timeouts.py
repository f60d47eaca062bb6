"""Review 1.6, 1.12, 1.13 (WEAK three rounds running): names and timeouts a machine cannot use.

- A blank event can never be sent (the API refuses a blank name) and a NUL in a name broke
  `cyborg graph` with a Graphviz syntax error; bidirectional overrides show a name other than
  the one the robot uses. Now each such state or event name is refused, naming it and the fix.
- ``timeouts.connect: 1e300`` made the controller wait forever for a missing module, and
  ``1.0e-9`` retried 64,000 times a second with a log line each. Now a timeout is refused below
  0.1 s or above an hour.
"""

from __future__ import annotations

import pytest

from cyborg.app.config import parse_config
from cyborg.errors import ConfigError

NAMES = """\
initial: idle
states:
  idle:
    action: x/idle
    transitions: {aborted: idle, "nul\\0x": idle, "": idle, " ": idle, "a\\u202eb": idle, "\\U0001F600go": shop}
  "bad\\tname": {action: x/bad, transitions: {aborted: idle}}
  shop: {action: x/shop, transitions: {aborted: idle}}
"""


def test_blank_names_and_control_characters_are_refused_naming_each() -> None:
    with pytest.raises(ConfigError) as raised:
        parse_config(NAMES, source="robot.yaml")
    problems = raised.value.problems
    text = "\n".join(problems)
    assert "event 'nul\\x00x'" in text and "U+0000" in text, text
    assert "event ''" in text and "event ' '" in text, text
    assert "event 'a\\u202eb'" in text and "U+202E" in text, text
    assert "state 'bad\\tname'" in text and "U+0009" in text, text
    assert all("fix: " in p for p in problems), problems
    assert len(problems) == 5, problems  # the emoji is a usable name


@pytest.mark.parametrize(
    ("timeouts", "says"),
    [
        ("{connect: 1e300}", "connect: must be less than or equal to 3600"),
        ("{connect: 1.0e-9}", "connect: must be greater than or equal to 0.1"),
        ("{preempt: 1e300}", "preempt: must be less than or equal to 3600"),
        ("{event_age: 0.001}", "event_age: must be greater than or equal to 0.1"),
    ],
)
def test_timeouts_out_of_any_use_are_refused(timeouts: str, says: str) -> None:
    text = f"initial: idle\ntimeouts: {timeouts}\nstates:\n  idle: {{action: x/idle, transitions: {{aborted: idle}}}}\n"
    with pytest.raises(ConfigError) as raised:
        parse_config(text, source="robot.yaml")
    assert says in str(raised.value) and "fix: " in str(raised.value), str(raised.value)
