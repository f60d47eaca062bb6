"""Recurring calendar events: RFC 5545 rules expanded in the event's own time zone.

Scheduled events ("be at the cafeteria every Wednesday 15:00-15:59") are stored with an
RFC 5545 recurrence: an RRULE, optionally with EXDATE/RDATE lines. They are expanded with
``dateutil.rrule`` in the event's own time zone (``zoneinfo``), so a weekly event at 15:00
Europe/Oslo stays at 15:00 local time across daylight-saving changes.

Expansion is windowed: a rule is checked once (INTERVAL and COUNT in range, some date
matches it, occurrences do not overlap) and each query starts the rule a whole number of
periods before its window instead of at the event's first start, so "every second since
1970" costs as little as "every Wednesday"; a query also stops after a bounded number of
occurrences (:mod:`cyborg.limits`). Every expansion runs under a budget of steps and CPU time
(:class:`Budget`): dateutil walks a sparse sub-daily rule (``FREQ=SECONDLY;BYMONTH=2;BYMONTHDAY=29``)
day by day through the years between its occurrences, which no count of occurrences bounds. A rule
stored before these checks that fails them is skipped with a logged warning, never expanded.

No clock is read here: every function takes the time it needs as an argument.
"""

from __future__ import annotations

import collections
import contextlib
import functools
import itertools
import logging
import re
import sys
import time as _time
from collections.abc import Iterator
from datetime import UTC, datetime, time, timedelta, tzinfo
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

from dateutil.relativedelta import relativedelta
from dateutil.rrule import rrule, rruleset, rrulestr

from cyborg.errors import CalendarError, DatabaseError, RuleTooCostly
from cyborg.limits import (
    MAX_EVENT_DAYS,
    MAX_OCCURRENCES_PER_QUERY,
    MAX_RULE_COUNT,
    MAX_RULE_SECONDS,
    MAX_RULE_STEPS,
    MAX_RULE_TOTAL_SECONDS,
)

RULE_EXAMPLE = "FREQ=WEEKLY;BYDAY=WE or FREQ=DAILY;COUNT=5"
_STAMP = re.compile(r"^(\d{8})(?:T(\d{6})(Z?))?$")
_FREQUENCIES = ("YEARLY", "MONTHLY", "WEEKLY", "DAILY", "HOURLY", "MINUTELY", "SECONDLY")
_FIXED_PERIODS = {
    "WEEKLY": timedelta(weeks=1),
    "DAILY": timedelta(days=1),
    "HOURLY": timedelta(hours=1),
    "MINUTELY": timedelta(minutes=1),
    "SECONDLY": timedelta(seconds=1),
}
_GREGORIAN_CYCLE_YEARS = 400
"""Dates, weekdays and leap years repeat every 400 years: a rule matching nothing in 400 years never matches."""
_OVERLAP_SAMPLE = 100
"""How many first occurrences the overlap check looks at."""
MAX_SCAN = 20 * MAX_OCCURRENCES_PER_QUERY
"""Most occurrences one query iterates over (including those before its window)."""

log = logging.getLogger(__name__)


# --- the work budget ------------------------------------------------------------------------


class Budget:
    """The work one expansion of a rule may take: MAX_RULE_STEPS steps and MAX_RULE_SECONDS of CPU time
    between two occurrences (:meth:`reset` at each), and MAX_RULE_TOTAL_SECONDS in all.

    A step is a Python call or generator resumption in this thread (dateutil takes one per period
    of the rule it looks at); the time is this thread's CPU time, so a loaded machine does not
    turn a usable rule into a refused one.
    """

    def __init__(self, what: str) -> None:
        self.what = what
        self._end = _time.thread_time() + MAX_RULE_TOTAL_SECONDS
        self.reset()

    def reset(self) -> None:
        """An occurrence was found: the next gap gets a budget of its own."""
        self._steps = 0
        self._deadline = min(self._end, _time.thread_time() + MAX_RULE_SECONDS)

    def __call__(self, frame: object, event: str, arg: object) -> None:
        self._steps += 1
        now = _time.thread_time()
        if now > self._end:
            raise RuleTooCostly(f"{self.what} takes over {MAX_RULE_TOTAL_SECONDS} s of work; fix: {_COARSER}")
        if self._steps > MAX_RULE_STEPS or now > self._deadline:
            raise RuleTooCostly(
                f"{self.what} takes over {MAX_RULE_STEPS:,} steps or {MAX_RULE_SECONDS} s of work from one "
                f"occurrence to the next; fix: {_COARSER}"
            )


_COARSER = (
    "use the coarsest FREQ that says the same, with the same BY... parts (FREQ=DAILY;BYHOUR=23 rather than "
    "FREQ=SECONDLY;BYHOUR=23, FREQ=YEARLY;BYMONTH=2;BYMONTHDAY=29;BYHOUR=23 rather than FREQ=SECONDLY;...): "
    "a sub-daily FREQ is walked through day by day, also on the days its BY... parts skip"
)


@contextlib.contextmanager
def bounded(what: str) -> Iterator[Budget]:
    """Raise RuleTooCostly inside the block once it goes over its :class:`Budget` (which it yields)."""
    budget = Budget(what)
    previous = sys.gettrace()
    sys.settrace(budget)
    try:
        yield budget
    finally:
        sys.settrace(previous)


# --- recurrence strings ----------------------------------------------------------------------


def _parse_stamp(value: str, zone: tzinfo, start: datetime, *, end_of_day: bool = False) -> datetime:
    """An iCalendar DATE or DATE-TIME value as an aware datetime (floating values are in ``zone``)."""
    m = _STAMP.match(value.strip())
    if m is None:
        raise CalendarError(
            f"{value!r} is not an iCalendar date (YYYYMMDD) or date-time (YYYYMMDDTHHMMSS[Z])"
        )
    day = datetime.strptime(m.group(1), "%Y%m%d").date()
    if m.group(2) is None:
        clock = time(23, 59, 59) if end_of_day else start.astimezone(zone).time()
        return datetime.combine(day, clock, zone)
    moment = datetime.combine(day, datetime.strptime(m.group(2), "%H%M%S").time())
    return moment.replace(tzinfo=UTC) if m.group(3) else moment.replace(tzinfo=zone)


def utc_stamp(moment: datetime) -> str:
    """``moment`` as an iCalendar UTC date-time (``20261123T140000Z``), the form stored recurrences use."""
    return moment.astimezone(UTC).strftime("%Y%m%dT%H%M%SZ")


def _line_zone(params: str, default: tzinfo) -> tzinfo:
    found = re.search(r"TZID=([^;:]+)", params, flags=re.IGNORECASE)
    return ZoneInfo(found.group(1).strip('"')) if found else default


def normalise_recurrence(text: str, start: datetime, end: datetime | None = None) -> str:
    """Check a recurrence and return it in stored form: ``RRULE:...`` then EXDATE/RDATE lines in UTC.

    ``text`` is a bare rule (``FREQ=WEEKLY``) or RFC 5545 lines (``RRULE:``, ``EXDATE:``,
    ``RDATE:``, optionally with ``;TZID=``). UNTIL and dates without ``Z`` are read in
    ``start``'s zone and converted to UTC. With ``end`` (the first occurrence's end), the
    occurrences must not overlap. Raises DatabaseError naming the bad part and the fix.
    """
    zone = start.tzinfo
    if zone is None:
        raise DatabaseError(
            f"start {start.isoformat()} has no time zone; give e.g. {start.isoformat()}+01:00"
        )
    lines: list[str] = []
    try:
        for raw in (part.strip() for part in text.strip().splitlines()):
            if not raw:
                continue
            head, sep, value = raw.partition(":")
            if not sep or "=" in head.partition(";")[0]:
                head, value = "RRULE", raw
            name, _, params = head.partition(";")
            name = name.upper()
            if name == "RRULE":
                lines.append("RRULE:" + _normalise_rule(value, zone, start))
            elif name in ("EXDATE", "RDATE"):
                line_zone = _line_zone(params, zone)
                stamps = [utc_stamp(_parse_stamp(v, line_zone, start)) for v in value.split(",")]
                lines.append(f"{name}:{','.join(stamps)}")
            else:
                raise CalendarError(f"unsupported line {raw!r}; use RRULE, EXDATE or RDATE")
        if not any(line.startswith("RRULE:") for line in lines):
            raise CalendarError("it has no RRULE")
        stored = "\n".join(lines)
        check_expansion(stored, start, None if end is None else end - start)
    except RuleTooCostly as exc:
        raise DatabaseError(f"recurrence {_short(text)} is not valid: {exc}") from exc
    except (ValueError, KeyError, OverflowError, ZoneInfoNotFoundError) as exc:
        raise DatabaseError(
            f"recurrence {_short(text)} is not valid ({exc}); write a rule like {RULE_EXAMPLE}"
        ) from exc
    return stored


def _short(text: str, limit: int = 120) -> str:
    return repr(text) if len(text) <= limit else repr(text[: limit - 3] + "...")


def _normalise_rule(value: str, zone: tzinfo, start: datetime) -> str:
    parts = []
    for part in value.strip().split(";"):
        key, sep, val = part.partition("=")
        if not sep:
            raise CalendarError(f"rule part {part!r} is not KEY=VALUE")
        key = key.strip().upper()
        if key == "UNTIL":
            val = utc_stamp(_parse_stamp(val, zone, start, end_of_day=True))
        parts.append(f"{key}={val.strip().upper()}")
    text = ";".join(parts)
    _check_parts(_rule_parts(text))
    return text


def _rule_parts(rule_text: str) -> dict[str, str]:
    """``FREQ=DAILY;COUNT=3`` as {"FREQ": "DAILY", "COUNT": "3"} (keys upper case)."""
    parts: dict[str, str] = {}
    for part in rule_text.split(";"):
        key, _, val = part.partition("=")
        parts[key.strip().upper()] = val.strip().upper()
    return parts


def _check_parts(parts: dict[str, str]) -> None:
    """Refuse what would make a rule repeat nothing, run backwards or never end its expansion."""
    freq = parts.get("FREQ")
    if freq not in _FREQUENCIES:
        raise RuleTooCostly(
            f"FREQ={freq or ''} is no frequency; fix: use one of {', '.join(_FREQUENCIES)}, e.g. {RULE_EXAMPLE}"
        )
    interval = parts.get("INTERVAL", "1")
    if not (interval.isdigit() and len(interval) <= 9 and int(interval) >= 1):
        raise RuleTooCostly(
            f"INTERVAL={interval} must be a whole number of at least 1 (how many {freq.lower()} periods "
            "between repeats); fix: e.g. INTERVAL=2 for every other one, or leave it out for 1"
        )
    count = parts.get("COUNT")
    if count is not None and not (count.isdigit() and len(count) <= 9 and 1 <= int(count) <= MAX_RULE_COUNT):
        raise RuleTooCostly(
            f"COUNT={count} must be a whole number from 1 to {MAX_RULE_COUNT} (how many times the event "
            "happens); fix: e.g. COUNT=10, or UNTIL=<last date> for a longer series"
        )
    if count is not None and "UNTIL" in parts:
        raise RuleTooCostly("it has both COUNT and UNTIL; fix: keep one of them (RFC 5545 allows only one)")
    if "BYSETPOS" in parts and freq in ("HOURLY", "MINUTELY", "SECONDLY"):
        raise RuleTooCostly(
            f"BYSETPOS with FREQ={freq} picks from single moments and can spin forever; fix: remove BYSETPOS "
            "or use FREQ=DAILY or coarser"
        )


def check_expansion(recurrence: str, start: datetime, length: timedelta | None = None) -> None:
    """Refuse a stored-form ``recurrence`` that expands to nothing, overlaps itself or too far.

    RuleTooCostly (a CalendarError, so a ValueError) says what and the fix; other ValueErrors come
    from dateutil.
    """
    rule_text = _rrule_text(recurrence)
    _check_parts(_rule_parts(rule_text))
    build_rule_set(recurrence, start)  # every line parses
    if length is not None and length > timedelta(days=MAX_EVENT_DAYS):
        raise RuleTooCostly(
            f"one occurrence lasts {length}, over the limit of {MAX_EVENT_DAYS} days; fix: check the end "
            "(or DTEND/DURATION) of the event"
        )
    first: list[datetime] = []
    if not _dates_never_match(rule_text, start):
        probe = _far_probe(rule_text, start)
        with bounded("finding its first occurrences") as budget:
            for occurrence in itertools.islice(probe, _OVERLAP_SAMPLE + 1):
                first.append(occurrence)
                budget.reset()
    if not first:
        raise RuleTooCostly(
            "no date matches all of its BY... parts, so it never repeats; fix: correct them (e.g. BYMONTH=2 "
            "with BYMONTHDAY=30 never happens)"
        )
    if length is not None:
        for earlier, later in itertools.pairwise(first):
            if later - earlier < length:
                raise RuleTooCostly(
                    f"its occurrences overlap: each lasts {length} but one starts {later - earlier} after the "
                    "last; fix: shorten the event or repeat it less often"
                )


def _rrule_text(recurrence: str) -> str:
    for line in recurrence.splitlines():
        if line.upper().startswith("RRULE:"):
            return line.partition(":")[2]
    raise CalendarError("it has no RRULE")


def _far_probe(rule_text: str, start: datetime) -> rrule:
    """The rule without COUNT and UNTIL, started a multiple of 400 years later (the same calendar).

    Started near year 9999, dateutil gives up at its end instead of searching thousands of
    years for a date that no BY... combination allows; the first occurrences are the same,
    shifted by the same number of years.
    """
    parts = {k: v for k, v in _rule_parts(rule_text).items() if k not in ("COUNT", "UNTIL")}
    cycles = max(0, (9999 - _GREGORIAN_CYCLE_YEARS - start.year) // _GREGORIAN_CYCLE_YEARS)
    far = start.replace(year=start.year + cycles * _GREGORIAN_CYCLE_YEARS)
    rule = rrulestr(";".join(f"{k}={v}" for k, v in parts.items()), dtstart=far)
    assert isinstance(rule, rrule)
    return rule


_DATE_PARTS = ("BYMONTH", "BYMONTHDAY", "BYYEARDAY", "BYDAY")


def _dates_never_match(rule_text: str, start: datetime) -> bool:
    """True if a daily or sub-daily rule's date parts match no day in 400 years.

    The same parts under FREQ=YEARLY pick the same days with one step a year, where the rule's own
    FREQ would walk every day of the 400 years to find that none matches.
    """
    parts = _rule_parts(rule_text)
    if parts.get("FREQ") not in ("DAILY", "HOURLY", "MINUTELY", "SECONDLY"):
        return False
    dates = {k: v for k, v in parts.items() if k in _DATE_PARTS}
    if not dates or any(c.isdigit() for c in dates.get("BYDAY", "").replace(",", "")):
        return False
    yearly = ";".join(["FREQ=YEARLY", *(f"{k}={v}" for k, v in dates.items())])
    probe = _far_probe(yearly, start.replace(hour=0, minute=0, second=0, microsecond=0))
    return next(iter(probe), None) is None


def build_rule_set(recurrence: str, start: datetime) -> rruleset:
    """The dateutil rule set of a stored recurrence; ``start`` is always the first occurrence."""
    rules = rrulestr(recurrence, dtstart=start, forceset=True)
    assert isinstance(rules, rruleset)
    rules.rdate(start)
    return rules


# --- occurrences -----------------------------------------------------------------------------


def occurrences_between(
    start: datetime,
    end: datetime,
    recurrence: str | None,
    window_start: datetime,
    window_end: datetime,
) -> list[tuple[datetime, datetime]]:
    """Occurrences (start, end) of an event that overlap ``[window_start, window_end)``, in order.

    Occurrences keep the wall-clock time and length of the first one in its own zone. At most
    :data:`~cyborg.limits.MAX_OCCURRENCES_PER_QUERY` are returned; a recurrence that fails
    :func:`check_expansion` (stored by an older version) yields nothing and a logged warning.
    """
    length = end - start
    if recurrence is None:
        starts = [start] if start < window_end else []
    else:
        if not _usable(recurrence, start, length) or (recurrence, start) in _TOO_COSTLY:
            return []
        try:
            starts = _starts(recurrence, start, window_start - length - timedelta(seconds=1), window_end)
        except RuleTooCostly as exc:
            _TOO_COSTLY.add((recurrence, start))
            log.warning(
                "calendar: skipping the event starting %s from now on: recurrence %r: %s",
                start,
                recurrence,
                exc,
            )
            return []
    found = []
    for occ in starts:
        occ_end = occ + length
        if occ_end > window_start:
            found.append((occ, occ_end))
    return found[:MAX_OCCURRENCES_PER_QUERY]


_TOO_COSTLY: set[tuple[str, datetime]] = set()
"""Rules (with their start) a query found over the work budget: skipped for the rest of the process."""

_SEEN_SPANS: dict[tuple[str, datetime], tuple[datetime, datetime | None, list[datetime]]] = {}
"""Per rule: (lower, upper, starts): every occurrence starting in [lower, upper) (None: forever)."""
_SEEN_SPAN_RULES = 1024
_SEEN_SPAN_STARTS = 64


def _starts(recurrence: str, start: datetime, lower: datetime, upper: datetime) -> list[datetime]:
    """The occurrence starts in [lower, upper), at most MAX_OCCURRENCES_PER_QUERY of them.

    The scheduler asks about a moving instant every few seconds; the span a scan has seen
    (up to the first occurrence after its window, however far a sparse rule puts it) answers
    the next questions inside it without expanding the rule again.
    """
    key = (recurrence, start)
    seen = _SEEN_SPANS.get(key)
    if seen is not None and seen[0] <= lower and (seen[1] is None or upper <= seen[1]):
        return [occ for occ in seen[2] if lower <= occ < upper]
    found: list[datetime] = []
    after: datetime | None = None
    with bounded("finding its occurrences") as budget:
        for scanned, occ in enumerate(_rules_near(recurrence, start, lower).xafter(lower, inc=True), start=1):
            budget.reset()
            if occ >= upper:
                after = occ
                break
            if len(found) >= MAX_OCCURRENCES_PER_QUERY + 2 or scanned >= MAX_SCAN:  # +2: before the window
                return found  # cut short: not a complete picture of the span, so not remembered
            found.append(occ)
    if len(found) <= _SEEN_SPAN_STARTS:
        if len(_SEEN_SPANS) >= _SEEN_SPAN_RULES:
            _SEEN_SPANS.clear()
        _SEEN_SPANS[key] = (lower, after, found)
    return found


@functools.lru_cache(maxsize=1024)
def _usable(recurrence: str, start: datetime, length: timedelta) -> bool:
    """Whether a stored recurrence passes :func:`check_expansion` (checked once per process)."""
    try:
        check_expansion(recurrence, start, length)
    except (ValueError, KeyError, OverflowError, ZoneInfoNotFoundError) as exc:
        log.warning("calendar: skipping the event starting %s: recurrence %r: %s", start, recurrence, exc)
        return False
    return True


def _rules_near(recurrence: str, start: datetime, lower: datetime) -> rruleset:
    """The rule set of ``recurrence``, with the rule started as late as possible but not after ``lower``.

    Moving the start by a whole number of the rule's periods (INTERVAL x FREQ, in wall-clock
    time of the start's zone) keeps every occurrence from the new start on; those before it
    are before the window. COUNT is first turned into the UNTIL of its last occurrence.
    """
    rule_text = _rrule_text(recurrence)
    parts = _rule_parts(rule_text)
    if "COUNT" in parts:
        last = _last_of_count(rule_text, start)
        parts.pop("COUNT")
        parts["UNTIL"] = utc_stamp(last)
    moved = _moved_start(parts, start, lower.astimezone(start.tzinfo))
    lines = ["RRULE:" + ";".join(f"{k}={v}" for k, v in parts.items())]
    lines += [line for line in recurrence.splitlines() if not line.upper().startswith("RRULE:")]
    rules = rrulestr("\n".join(lines), dtstart=moved, forceset=True)
    assert isinstance(rules, rruleset)
    rules.rdate(start)
    return rules


@functools.lru_cache(maxsize=1024)
def _last_of_count(rule_text: str, start: datetime) -> datetime:
    """The last occurrence of a rule with COUNT (at most MAX_RULE_COUNT of them)."""
    rule = rrulestr(rule_text, dtstart=start)
    tail: collections.deque[datetime] = collections.deque(maxlen=1)
    with bounded("finding its last occurrence") as budget:
        for occurrence in itertools.islice(rule, MAX_RULE_COUNT):
            tail.append(occurrence)
            budget.reset()
    return tail[0] if tail else start


def _moved_start(parts: dict[str, str], start: datetime, lower: datetime) -> datetime:
    """``start`` moved forward by whole periods to at most one period before ``lower``."""
    if lower <= start:
        return start
    interval = int(parts.get("INTERVAL", "1"))
    freq = parts["FREQ"]
    if freq in _FIXED_PERIODS:
        period = _FIXED_PERIODS[freq] * interval
        steps = (lower.replace(tzinfo=None) - start.replace(tzinfo=None)) // period - 1
        return start + period * steps if steps > 0 else start
    months = 12 if freq == "YEARLY" else 1
    gap = (lower.year - start.year) * 12 + lower.month - start.month
    steps = gap // (months * interval) - 1
    for back in range(steps, max(steps - 48, 0), -1):  # a 29th-31st must exist in the new month
        moved = start + relativedelta(months=back * months * interval)
        if moved.day == start.day:
            return moved
    return start


def ongoing_occurrence(
    start: datetime, end: datetime, recurrence: str | None, now: datetime
) -> tuple[datetime, datetime] | None:
    """The occurrence with ``occ_start <= now < occ_end``, or None (the latest if several overlap)."""
    if now.tzinfo is None:
        raise CalendarError(
            f"now={now.isoformat()} is naive; pass an aware time, e.g. datetime.now(timezone.utc)"
        )
    hits = [
        (s, e)
        for s, e in occurrences_between(start, end, recurrence, now, now + timedelta(microseconds=1))
        if s <= now < e
    ]
    return hits[-1] if hits else None
