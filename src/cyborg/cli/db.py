"""``cyborg db``: look at and edit the navigation database from the command line.

Part of the navigation module, a thin command-line layer over
:class:`~cyborg.navigation.database.NavigationDatabase` and
:func:`~cyborg.navigation.ics.import_ics`. Subcommands list, add and remove
locations, calendar events and responses, import an .ics calendar and import the
named goals of a map as locations. Bad input prints what is wrong and how to fix
it and exits with code 2, writing nothing.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

import click

from cyborg.errors import CyborgError
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.ics import DEFAULT_TIMEZONE, import_ics
from cyborg.navigation.models import CalendarEvent, Location, Response, ResponseType

DB_FILE = "navigation.db"


def default_db_path() -> Path:
    """``$CYBORG_DATA_DIR/navigation.db``, else ``~/.local/share/cyborg/navigation.db``."""
    env = os.environ.get("CYBORG_DATA_DIR")
    folder = Path(env) if env else Path.home() / ".local" / "share" / "cyborg"
    return folder / DB_FILE


class InputError(CyborgError, click.ClickException):
    """Bad input from the user: printed as 'Error: ...', exit code 2."""

    exit_code = 2


@contextmanager
def _open(ctx: click.Context) -> Iterator[NavigationDatabase]:
    """The database named by ``--db``; CyborgErrors become InputError (exit 2)."""
    try:
        with NavigationDatabase(ctx.obj, recover=False) as db:  # never move the user's file aside
            yield db
    except CyborgError as exc:
        raise InputError(str(exc)) from exc


def _table(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """A plain-text table with left-aligned columns."""
    cells = [[str(h) for h in headers], *[[_cell(v) for v in row] for row in rows]]
    widths = [max(len(row[i]) for row in cells) for i in range(len(headers))]
    lines = [
        "  ".join(value.ljust(width) for value, width in zip(row, widths, strict=True)).rstrip()
        for row in cells
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _cell(value: object) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.2f}"
    if isinstance(value, datetime):
        return value.strftime("%Y-%m-%d %H:%M %Z")
    return str(value).replace("\n", " ")


@click.group("db", context_settings={"help_option_names": ["-h", "--help"]})
@click.option(
    "--db",
    "db_path",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="navigation database (default: $CYBORG_DATA_DIR/navigation.db or ~/.local/share/cyborg/navigation.db)",
)
@click.pass_context
def db_group(ctx: click.Context, db_path: Path | None) -> None:
    """Locations, calendar events and responses of the navigation module."""
    ctx.obj = db_path if db_path is not None else default_db_path()


# --- locations -------------------------------------------------------------------------------


@db_group.group("locations", invoke_without_command=True)
@click.pass_context
def locations(ctx: click.Context) -> None:
    """Known places: list (also without a subcommand), add, set-pose, remove."""
    if ctx.invoked_subcommand is None:
        ctx.invoke(locations_list)


@locations.command("list")
@click.pass_context
def locations_list(ctx: click.Context) -> None:
    """Show every location with its aliases and pose ('-': no pose, so no target)."""
    with _open(ctx) as db:
        places = db.list_locations()
        current = db.current_map()
    rows = [
        (
            loc.name,
            ", ".join(loc.aliases),
            loc.map or None,
            loc.x,
            loc.y,
            loc.heading if loc.position else None,
            loc.tolerance,
            loc.crowded,
            loc.pleasantness,
        )
        for loc in places
    ]
    headers = ("name", "aliases", "map", "x", "y", "heading", "tolerance", "crowded", "pleasant")
    click.echo(_table(headers, rows))
    if current is not None:
        click.echo(f"map in use: {current} (places on other maps are not targets)")
    unplaced = [loc.name for loc in places if loc.position is None]
    if unplaced:
        click.echo(
            f"no pose: {', '.join(unplaced)} (not targets: asked for one, the robot says it does not know "
            "where it is)\ngive one a pose: import a map whose goals name it (cyborg db import-map MAP), "
            "or: cyborg db locations set-pose NAME --x X --y Y [--heading RAD]"
        )


@locations.command("add")
@click.argument("name")
@click.option("--alias", "aliases", multiple=True, help="another name STT may hear (repeatable)")
@click.option("--map", "map_name", default="", help="name of the map the pose is on")
@click.option("--x", type=float, default=None, help="metres (with --y; leave both out if not known yet)")
@click.option("--y", type=float, default=None, help="metres (with --x)")
@click.option("--heading", type=float, default=0.0, show_default=True, help="radians")
@click.option("--tolerance", type=float, default=0.5, show_default=True, help="arrival tolerance, metres")
@click.option("--crowded/--not-crowded", default=False, show_default=True)
@click.option("--pleasantness", type=float, default=0.0, show_default=True, help="-1 (awful) .. 1 (lovely)")
@click.pass_context
def locations_add(
    ctx: click.Context,
    name: str,
    aliases: tuple[str, ...],
    map_name: str,
    x: float | None,
    y: float | None,
    heading: float,
    tolerance: float,
    crowded: bool,
    pleasantness: float,
) -> None:
    """Add location NAME (without --x and --y it has no pose and is no target until it gets one)."""
    location = Location(name, aliases, map_name, x, y, heading, tolerance, crowded, pleasantness)
    with _open(ctx) as db:
        added = db.add_location(location)
    pose = "no pose yet" if added.position is None else f"at ({added.x:.2f}, {added.y:.2f})"
    click.echo(f"added location {added.name!r}, {pose}")


@locations.command("set-pose")
@click.argument("name")
@click.option("--x", type=float, required=True, help="metres")
@click.option("--y", type=float, required=True, help="metres")
@click.option("--heading", type=float, default=0.0, show_default=True, help="radians")
@click.option("--map", "map_name", default=None, help="map the pose is on (default: the map in use)")
@click.pass_context
def locations_set_pose(
    ctx: click.Context, name: str, x: float, y: float, heading: float, map_name: str | None
) -> None:
    """Give location NAME (a name or an alias) a pose; its aliases and events are kept."""
    with _open(ctx) as db:
        placed = db.set_pose(name, x, y, heading, map_name)
    where = f" on map {placed.map!r}" if placed.map else ""
    click.echo(f"location {placed.name!r} is at ({x:.2f}, {y:.2f}){where}")


@locations.command("remove")
@click.argument("name")
@click.option("--with-events", is_flag=True, help="also remove the location's calendar events")
@click.pass_context
def locations_remove(ctx: click.Context, name: str, with_events: bool) -> None:
    """Remove location NAME (a name or an alias)."""
    with _open(ctx) as db:
        removed = db.remove_location(name, with_events=with_events)
    click.echo(f"removed location {removed.name!r}")


# --- calendar events -------------------------------------------------------------------------


def _parse_time(value: str, zone_name: str, label: str) -> datetime:
    """An ISO 8601 time; without an offset it is read in ``zone_name``; 'now' is the current time."""
    try:
        zone = ZoneInfo(zone_name)
    except (ZoneInfoNotFoundError, ValueError) as exc:
        raise InputError(f"unknown time zone {zone_name!r}; use an IANA name such as Europe/Oslo") from exc
    if value.strip().lower() == "now":
        return datetime.now(UTC).astimezone(zone)
    try:
        moment = datetime.fromisoformat(value.strip())
    except ValueError as exc:
        raise InputError(f"{label} {value!r} is not an ISO 8601 time; write e.g. 2024-03-20T15:00") from exc
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=zone)


@db_group.group("events")
def events() -> None:
    """Scheduled visits: list, add, remove."""


@events.command("list")
@click.option("--location", default=None, help="only this location's events")
@click.option("--at", "at", default=None, help="only events ongoing at this time (ISO 8601 or 'now')")
@click.option(
    "--tz", "zone", default=DEFAULT_TIMEZONE, show_default=True, help="zone of times without offset"
)
@click.pass_context
def events_list(ctx: click.Context, location: str | None, at: str | None, zone: str) -> None:
    """Show calendar events (their first occurrence and the recurrence rule)."""
    moment = _parse_time(at, zone, "--at") if at is not None else None
    with _open(ctx) as db:
        if moment is None:
            shown = db.list_events(location)
        else:
            wanted = db.get_location(location).name if location else None
            shown = [o.event for o in db.ongoing_events(moment) if wanted in (None, o.event.location)]
    rows = [(e.id, e.location, e.start, e.end, e.recurrence, e.ignored, e.summary, e.uid) for e in shown]
    click.echo(_table(("id", "location", "start", "end", "recurrence", "ignored", "summary", "uid"), rows))


@events.command("add")
@click.argument("location")
@click.argument("start")
@click.argument("end")
@click.option(
    "--tz", "zone", default=DEFAULT_TIMEZONE, show_default=True, help="zone of times without offset"
)
@click.option("--rrule", default=None, help="RFC 5545 recurrence, e.g. FREQ=WEEKLY;BYDAY=WE")
@click.option("--summary", default=None)
@click.option("--uid", default=None, help="unique id (an .ics import sets it)")
@click.option("--ignore", is_flag=True, help="store the event but do not act on it")
@click.pass_context
def events_add(
    ctx: click.Context,
    location: str,
    start: str,
    end: str,
    zone: str,
    rrule: str | None,
    summary: str | None,
    uid: str | None,
    ignore: bool,
) -> None:
    """Be at LOCATION from START to END (ISO 8601, e.g. 2024-03-20T15:00)."""
    event = CalendarEvent(
        location,
        _parse_time(start, zone, "START"),
        _parse_time(end, zone, "END"),
        ignored=ignore,
        recurrence=rrule,
        summary=summary,
        uid=uid,
    )
    with _open(ctx) as db:
        added = db.add_event(event)
    click.echo(f"added event {added.id} at {added.location!r}")


@events.command("remove")
@click.argument("event_id", type=int)
@click.pass_context
def events_remove(ctx: click.Context, event_id: int) -> None:
    """Remove the calendar event with id EVENT_ID."""
    with _open(ctx) as db:
        removed = db.remove_event(event_id)
    click.echo(f"removed event {event_id} at {removed.location!r}")


# --- responses -------------------------------------------------------------------------------

_TYPES = click.Choice([t.value for t in ResponseType])


@db_group.group("responses")
def responses() -> None:
    """Things to say: list, add, remove."""


@responses.command("list")
@click.option("--type", "kind", type=_TYPES, default=None)
@click.option("--emotion", default=None, help="only sentences stored for this emotion")
@click.pass_context
def responses_list(ctx: click.Context, kind: str | None, emotion: str | None) -> None:
    """Show stored sentences ('-' emotion: fits any emotion)."""
    with _open(ctx) as db:
        found = db.list_responses(ResponseType(kind) if kind else None, emotion)
    click.echo(
        _table(
            ("id", "type", "emotion", "sentence"),
            [(r.id, r.type.value, r.emotion, r.sentence) for r in found],
        )
    )


@responses.command("add")
@click.argument("kind", metavar="TYPE", type=_TYPES)
@click.argument("sentence")
@click.option("--emotion", default=None, help="emotion it fits (default: any)")
@click.pass_context
def responses_add(ctx: click.Context, kind: str, sentence: str, emotion: str | None) -> None:
    """Add SENTENCE of TYPE; LOCATION in it is replaced by the place's name."""
    with _open(ctx) as db:
        added = db.add_response(Response(sentence, ResponseType(kind), emotion))
    click.echo(f"added response {added.id}")


@responses.command("remove")
@click.argument("response_id", type=int)
@click.pass_context
def responses_remove(ctx: click.Context, response_id: int) -> None:
    """Remove the response with id RESPONSE_ID."""
    with _open(ctx) as db:
        removed = db.remove_response(response_id)
    click.echo(f"removed response {response_id}: {removed.sentence!r}")


# --- imports ---------------------------------------------------------------------------------


@db_group.command("import-ics")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--default-location", default=None, help="place for events that name no known place")
@click.option(
    "--tz", "zone", default=DEFAULT_TIMEZONE, show_default=True, help="zone of floating/all-day times"
)
@click.pass_context
def import_ics_command(ctx: click.Context, file: Path, default_location: str | None, zone: str) -> None:
    """Import the events of an iCalendar FILE; importing it again updates them."""
    with _open(ctx) as db:
        report = import_ics(db, file, default_location, local_tz=zone)
    click.echo(f"added {len(report.added)}, updated {len(report.updated)}, skipped {len(report.skipped)}")
    for skipped in report.skipped:
        click.echo(f"skipped {skipped.summary!r}: {skipped.reason}")


def _map_loader() -> Callable[[Path], Any]:
    try:
        from cyborg.maps import load_map
    except ImportError as exc:
        raise InputError(
            f"the map reader cyborg.maps is not available ({exc}); "
            "update cyborg, or add the locations with `cyborg db locations add`"
        ) from exc
    return load_map


@db_group.command("import-map")
@click.argument("map_file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--map-name", default=None, help="name stored with each pose (default: the file's stem)")
@click.pass_context
def import_map(ctx: click.Context, map_file: Path, map_name: str | None) -> None:
    """Import the named goals of MAP_FILE as locations (known ones get the map's pose)."""
    try:
        occupancy = _map_loader()(map_file)
    except CyborgError as exc:
        raise InputError(str(exc)) from exc
    poses: Iterable[Any] = getattr(occupancy, "named_poses", None) or getattr(occupancy, "poses", None) or ()
    name = map_name or map_file.stem
    with _open(ctx) as db:
        for pose in poses:
            click.echo(db.import_pose(pose, name))
