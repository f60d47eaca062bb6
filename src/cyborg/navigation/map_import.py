"""Turning a map's goal poses into places of the navigation database.

Used by :meth:`~cyborg.navigation.database.NavigationDatabase.import_pose` (``cyborg db
import-map`` and the robot's start-up read a map's goals through it); works on the places
of :class:`~cyborg.navigation.locations.LocationStore`. A goal named like a known place
moves it; a goal named like a default place after normalisation (``waitingarea`` ~
"waiting area", ``elevator1`` ~ "elevator") places that default place; any other goal
becomes a new place.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from typing import Any

from cyborg.errors import CyborgError
from cyborg.navigation.content import DEFAULT_LOCATIONS
from cyborg.navigation.keywords import normalise
from cyborg.navigation.locations import LocationStore
from cyborg.navigation.models import Location


def import_pose(db: LocationStore, pose: Any, map_name: str) -> str:
    """Add or update one location of ``db`` from a map pose; a line saying what happened.

    ``map_name`` becomes the map in use (:meth:`~LocationStore.use_map`). A pose whose name
    is a known name or alias moves that place. Else, a pose named like a default place after
    normalisation (``waitingarea`` ~ "waiting area", ``elevator1`` ~ "elevator": the first of
    several) places that default place and becomes its alias, unless another pose of this map
    placed it already.
    """
    db.use_map(map_name)
    x, y, heading = float(pose.x), float(pose.y), float(pose.theta)
    if not all(math.isfinite(v) for v in (x, y, heading)):
        return f"skipped {pose.name!r}: its pose ({x}, {y}, {heading}) is not finite"
    known = db.find_location(pose.name)
    try:
        if known is None:
            default = _default_place_named_like(db, pose.name, map_name.strip())
            if default is not None:
                spoken = {normalise(form) for form in (default.name, *default.aliases)}
                aliases = default.aliases
                if normalise(pose.name) not in spoken:
                    aliases = (*aliases, " ".join(str(pose.name).split()))
                moved = replace(default, aliases=aliases, map=map_name, x=x, y=y, heading=heading)
                db.update_location(default.name, moved)
                return f"updated {default.name!r} (the map's {pose.name!r}) to ({x:.2f}, {y:.2f})"
            db.add_location(Location(pose.name, map=map_name, x=x, y=y, heading=heading))
            return f"added {pose.name!r} at ({x:.2f}, {y:.2f})"
        db.update_location(known.name, replace(known, map=map_name, x=x, y=y, heading=heading))
        return f"updated {known.name!r} to ({x:.2f}, {y:.2f})"
    except CyborgError as exc:
        return f"skipped {pose.name!r}: {exc}"


def _default_place_named_like(db: LocationStore, name: str, map_name: str) -> Location | None:
    """The stored default place a map goal called ``name`` stands for, if not on ``map_name`` yet."""
    key = _compact(name)
    keys = [key]
    first = re.fullmatch(r"(.*\D)1", key)  # "elevator1": the first elevator is "the elevator"
    if first:
        keys.append(first.group(1))
    for wanted in keys:
        for default in DEFAULT_LOCATIONS:
            if all(_compact(form) != wanted for form in (default.name, *default.aliases)):
                continue
            place = db.find_location(default.name)
            if place is not None and place.map != map_name:
                return place
    return None


def _compact(name: str) -> str:
    """A name as speech would match it, without spaces: "Waiting Area" and "waitingarea" -> "waitingarea"."""
    return "".join(normalise(name).split())
