"""The content a new navigation database starts with, read from the YAML files shipped in the package.

Sits between the value types (:mod:`~cyborg.navigation.models`) and the schema
(:mod:`~cyborg.navigation.schema`), which seeds a new file from here. The default places
and their aliases are in ``navigation/data/places.yaml``, the sentences in
``navigation/data/sentences.yaml``: content is edited there, not in Python. Both are read
with the safe YAML loader and checked (pydantic, then the same checks the database makes);
a broken file raises :class:`~cyborg.errors.ConfigError` naming the file, the entry and the fix.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from cyborg.configfile import describe_errors, load_yaml, read_text_file
from cyborg.errors import ConfigError, DatabaseError
from cyborg.navigation.keywords import normalise
from cyborg.navigation.models import (
    Location,
    Response,
    ResponseType,
    checked_sentence,
    valid_location,
)

PLACES_FILE = Path(str(resources.files("cyborg") / "navigation" / "data" / "places.yaml"))
"""The default places (Glassgården, NTNU), with their aliases; they have no pose."""
SENTENCES_FILE = Path(str(resources.files("cyborg") / "navigation" / "data" / "sentences.yaml"))
"""The default sentences, by response type and emotion."""

_KINDS = ", ".join(kind.value for kind in ResponseType)
_FIXES = {
    "name": "give the place's name as text, e.g. name: cafeteria (quote names YAML reads otherwise)",
    "aliases": "give a list of words, e.g. aliases: [canteen, cafe]",
    "crowded": "write true or false",
    "pleasantness": "give a number from -1 (hated) to 1 (loved), e.g. 0.3",
    "tolerance": "give the distance in metres that counts as arrived, above 0, e.g. 0.5",
    "sentence": "write what the robot says as text, e.g. sentence: I like the LOCATION.",
    "emotion": "give an emotion's name, e.g. emotion: elated, or leave the line out for any emotion",
}


class _Place(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)

    name: str
    aliases: list[str] = Field(default_factory=list)
    crowded: bool = False
    pleasantness: float = Field(0.0, ge=-1.0, le=1.0)
    tolerance: float = Field(0.5, gt=0.0)


class _Sentence(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)

    sentence: str
    emotion: str | None = None


def load_places(path: Path = PLACES_FILE) -> tuple[Location, ...]:
    """The places of ``path`` (a YAML list of places), checked; ConfigError lists every problem."""
    data = _read(path, "a list of places, e.g. '- name: cafeteria'")
    if not isinstance(data, list):
        raise ConfigError(
            f"it holds a {type(data).__name__}, not a list of places; fix: start each place with "
            "'- name: ...' (see the comment at the top of the shipped file)",
            source=str(path),
        )
    problems: list[str] = []
    places: list[Location] = []
    taken: dict[str, str] = {}
    for number, raw in enumerate(data, start=1):
        where = f"place {number}" + (f" ({raw['name']!r})" if isinstance(raw, dict) and "name" in raw else "")
        try:
            entry = _Place.model_validate(raw)
            place = valid_location(
                Location(
                    entry.name,
                    tuple(entry.aliases),
                    tolerance=entry.tolerance,
                    crowded=entry.crowded,
                    pleasantness=entry.pleasantness,
                )
            )
        except ValidationError as exc:
            problems += _explain(where, _Place, exc)
            continue
        except DatabaseError as exc:
            problems.append(f"{where}: {exc}")
            continue
        for form in (place.name, *place.aliases):
            owner = taken.setdefault(normalise(form), place.name)
            if owner != place.name:
                problems.append(
                    f"{where}: {form!r} is already used by place {owner!r}; fix: give one of them another "
                    "name or alias"
                )
        places.append(place)
    if problems:
        raise ConfigError(problems, source=str(path))
    return tuple(places)


def load_sentences(path: Path = SENTENCES_FILE) -> tuple[Response, ...]:
    """The sentences of ``path`` (response type -> list of sentences), checked; ConfigError lists every problem."""
    data = _read(path, "response types with their sentences, e.g. 'opinion:'")
    if not isinstance(data, dict):
        raise ConfigError(
            f"it holds a {type(data).__name__}, not response types with their sentences; fix: write "
            "'opinion:' then '  - sentence: I like the LOCATION.' (see the shipped file)",
            source=str(path),
        )
    problems: list[str] = []
    responses: list[Response] = []
    broken: set[ResponseType] = set()  # kinds with a problem already: no second one about them
    for key, entries in data.items():
        try:
            kind = ResponseType(key)
        except ValueError:
            problems.append(f"{key!r} is no kind of sentence; fix: use one of {_KINDS}")
            continue
        if not isinstance(entries, list):
            broken.add(kind)
            problems.append(
                f"{kind.value}: holds a {type(entries).__name__}, not a list; fix: write each sentence as "
                "'  - sentence: ...' below it"
            )
            continue
        seen: set[tuple[str, str | None]] = set()
        for number, raw in enumerate(entries, start=1):
            where = f"{kind.value} sentence {number}"
            try:
                entry = _Sentence.model_validate(raw)
                response = checked_sentence(Response(entry.sentence, kind, entry.emotion))
            except ValidationError as exc:
                broken.add(kind)
                problems += _explain(where, _Sentence, exc)
                continue
            except DatabaseError as exc:
                broken.add(kind)
                problems.append(f"{where}: {exc}")
                continue
            if (response.sentence, response.emotion) in seen:
                problems.append(f"{where}: {response.sentence!r} appears twice; fix: remove one")
                continue
            seen.add((response.sentence, response.emotion))
            responses.append(response)
    for kind in ResponseType:
        if kind not in broken and not any(r.type is kind and r.emotion is None for r in responses):
            problems.append(
                f"{kind.value}: no sentence fits any emotion, so the robot may have nothing to say; fix: add "
                f"one without 'emotion:' under '{kind.value}:'"
            )
    if problems:
        raise ConfigError(problems, source=str(path))
    return tuple(responses)


def _read(path: Path, expected: str) -> Any:
    try:
        text = read_text_file(path)
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(
            f"cannot read it ({exc}); fix: reinstall cyborg, or restore the file from git", source=str(path)
        ) from exc
    data = load_yaml(text, str(path))
    if data is None:
        raise ConfigError(f"it is empty; fix: it should hold {expected}", source=str(path))
    return data


def _explain(where: str, model: type[BaseModel], exc: ValidationError) -> list[str]:
    """One line per problem: the entry, the key, what is wrong with the value and the fix."""
    fixes: dict[tuple[str, ...], str] = {(key,): fix for key, fix in _FIXES.items()}
    fixes["aliases", "*"] = (
        "write each alias as text, in quotes if YAML would read it otherwise, e.g. ['no', lift]"
    )
    return describe_errors(
        exc, model, where=where, fixes=fixes, doc="the comment at the top of the shipped file"
    )


DEFAULT_LOCATIONS: tuple[Location, ...] = load_places()
"""The places a new database starts with (from ``places.yaml``); no poses: a map's goals
(``cyborg db import-map``) or ``set-pose`` give them."""
DEFAULT_RESPONSES: tuple[Response, ...] = load_sentences()
"""The sentences a new database starts with (from ``sentences.yaml``)."""
