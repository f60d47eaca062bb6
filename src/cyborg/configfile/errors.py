"""One translator from pydantic's validation errors to problem lines a user can act on.

Every line reads ``where: what is wrong (what was given); fix: how``, e.g.
``timeouts > connect: must be a number, not the text 'fast'; fix: write it as a number,
e.g. connect: 2.0 (seconds to wait for a module's action server)``. The fix comes, in
this order, from the caller's ``fixes`` table, from the model's own words (a validator's
``"what: fix"`` message, a field's ``examples``, default and ``description``), or from
the kind of value that was expected.

Locations are named by the caller's ``name`` function (the robot's YAML calls a state
``state 'idle'``, a scenario script adds line numbers); :func:`name_location` is the plain one.
"""

from __future__ import annotations

import datetime
import difflib
import enum
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import UnionType
from typing import TYPE_CHECKING, Any, TypeGuard, Union, get_args, get_origin

if TYPE_CHECKING:  # imported when a problem is worded: reading a file needs no pydantic (issue 33)
    from pydantic import BaseModel, ValidationError
    from pydantic.fields import FieldInfo
    from pydantic_core import ErrorDetails

Location = Sequence[Any]
"""Where a value is in a file: keys and list indexes from the top, as pydantic gives them."""

Namer = Callable[[Location], str]
"""Names a location for the reader, e.g. ('states', 'idle', 'action') -> "state 'idle' > action"."""

Fixes = Mapping[tuple[Any, ...], str]
"""How to write the value at a location, keyed by its pattern (see :func:`describe_errors`)."""


def name_location(loc: Location, labels: Mapping[str, str] | None = None) -> str:
    """``timeouts > connect``; a list index is ``entry 3``; the empty location is ``top level``.

    ``labels`` names the entries of a container key: with ``{"states": "state"}``,
    ('states', 'idle', 'action') is ``state 'idle' > action`` and ('steps', 0) is
    ``step 1`` given ``{"steps": "step"}``.
    """
    labels = labels or {}
    parts: list[str] = []
    i = 0
    while i < len(loc):
        part = loc[i]
        label = labels.get(part) if isinstance(part, str) else None
        if label is not None and i + 1 < len(loc):
            entry = loc[i + 1]
            parts.append(f"{label} {entry + 1}" if isinstance(entry, int) else f"{label} {entry!r}")
            i += 2
            continue
        parts.append(f"entry {part + 1}" if isinstance(part, int) else str(part))
        i += 1
    return " > ".join(parts) if parts else "top level"


def suggest(name: str, choices: Sequence[str]) -> str:
    """`` (did you mean 'idle'?)`` for the closest of ``choices``, or nothing."""
    close = difflib.get_close_matches(name, list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def yaml_kind(value: Any) -> str:
    """How a YAML user would call the type of ``value``: 'the number 3', 'a list [1, 2]'..."""
    if value is None:
        return "an empty value"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, int | float):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the text {_short(value)}"
    if isinstance(value, list):
        return f"a list {_short(value)}"
    if isinstance(value, dict):
        return f"a mapping {_short(value)}"
    return _short(value)


def describe_errors(
    exc: ValidationError,
    model: type[BaseModel],
    *,
    where: str = "",
    name: Namer = name_location,
    fixes: Fixes | None = None,
    doc: str = "the documentation of this file",
) -> list[str]:
    """One line per problem in ``exc``, raised by validating data against ``model``.

    ``where`` prefixes every location (``where="module 'greeter'"`` gives
    ``module 'greeter' > interval: ...``). ``name`` names the locations inside the model.
    ``fixes`` overrides the fix for a location by its pattern: a tuple of keys in which
    each name of a mapping entry or list index is ``*``, either from the top of ``model``
    (``("timeouts",)``) or from a model class found on the way (``(StateModel,
    "transitions", "*")``, ``(StateModel,)`` for a value that should be a state); the
    innermost match wins. ``doc`` is where a validator's message without a fix sends the reader.
    An unknown key is answered with the model's keys, less those declared ``exclude=True``
    (internal fields such as a step's line number).
    """
    context = _Context(model, where, name, fixes or {}, doc)
    lines = [context.describe(error) for error in exc.errors()]
    return list(dict.fromkeys(lines))  # a value that fits no member of a union is reported per member


class _Context:
    def __init__(self, model: type[BaseModel], where: str, name: Namer, fixes: Fixes, doc: str) -> None:
        self.model = model
        self.where = where.strip().removesuffix(">").strip()
        self.name = name
        self.fixes = fixes
        self.doc = doc

    def locate(self, loc: Location) -> str:
        named = self.name(loc) if loc or not self.where else ""
        if not self.where:
            return named
        return f"{self.where} > {named}" if named else self.where

    def describe(self, error: ErrorDetails) -> str:
        """The line a user reads for ``error`` (``where: what is wrong; fix: how``), worded by its type."""
        types, loc = _annotations(self.model, error["loc"])
        if loc and loc[-1] == "[key]":  # the key of a mapping entry, not its value
            return (
                f"{self.locate(loc[:-2])}: the key {loc[-2]!r} is not text; fix: put the name in quotes so "
                "YAML reads it as text (unquoted numbers, yes, no, on, off, true, false, null and ~ are "
                "not names)"
            )
        info = _field(types, loc)
        description = f" ({info.description})" if info is not None and info.description else ""
        problem = _Problem(error, types, loc, self.locate(loc), info, description)
        return _wording(error["type"])(self, problem)

    def fix(self, loc: Location, types: list[Any]) -> str:
        """The fix for a value of the wrong size or shape: the table's, else its expected form."""
        known = self.known_fix(loc, types)
        if known is not None:
            return known
        info = _field(types, loc)
        expected, example = _expected(types[-1])
        if info is not None and info.examples:
            example = _example(loc, info, types[-1])
        return f"write it as {expected}, e.g. {example}"

    def known_fix(self, loc: Location, types: list[Any]) -> str | None:
        for pattern in _patterns(loc, types):
            if pattern in self.fixes:
                return self.fixes[pattern]
        return None


@dataclass(frozen=True)
class _Problem:
    """One validation error with what its wording needs: where it is, the declared types, the field."""

    error: ErrorDetails
    types: list[Any]
    """The declared type at each prefix of ``loc`` (see :func:`_annotations`)."""
    loc: list[Any]
    """The location without pydantic's union tags."""
    where: str
    """The location named for the reader."""
    info: FieldInfo | None
    description: str
    """`` (the field's description)``, or nothing."""

    @property
    def kind(self) -> str:
        return self.error["type"]

    @property
    def value(self) -> Any:
        return self.error.get("input")

    @property
    def ctx(self) -> dict[str, Any]:
        return self.error.get("ctx", {})


Wording = Callable[[_Context, _Problem], str]
"""Words one kind of problem: ``where: what is wrong; fix: how``."""


def _unknown_key(context: _Context, p: _Problem) -> str:
    parent = p.types[-2] if len(p.types) >= 2 else None
    known = [k for k, f in parent.model_fields.items() if not f.exclude] if _is_model(parent) else []
    listed = f"; the keys here are: {', '.join(known)}" if known else ""
    return (
        f"{p.where}: unknown key {p.loc[-1]!r}{suggest(str(p.loc[-1]), known)}; "
        f"fix: remove it or correct its spelling{listed}"
    )


def _missing(context: _Context, p: _Problem) -> str:
    container = p.types[-2] if len(p.types) >= 2 else None
    if get_origin(container) is tuple:  # a list of fixed length, one item short
        fix = context.fix(p.loc[:-1], p.types[:-1])
        return f"{context.locate(p.loc[:-1])}: has too few {_items(container)}; fix: {fix}"
    fix = context.known_fix(p.loc, p.types) or f"add it (e.g. {_example(p.loc, p.info, p.types[-1])})"
    return f"{p.where}: missing {p.loc[-1]!r}{p.description}; fix: {fix}"


def _too_long(context: _Context, p: _Problem) -> str:
    if get_origin(p.types[-1]) is tuple:  # a list of fixed length
        return f"{p.where}: has too many {_items(p.types[-1])}; fix: {context.fix(p.loc, p.types)}"
    return _out_of_limits(context, p)


def _validator_message(context: _Context, p: _Problem) -> str:
    """A validator's own ``what: fix`` (or ``what; fix: how``) message."""
    text = p.error["msg"].removeprefix("Value error, ").removeprefix("Assertion failed, ")
    what, _, fix = text.partition("; fix: ") if "; fix: " in text else text.partition(": ")
    return f"{p.where}: {what}; fix: {fix or 'see ' + context.doc}"


def _not_a_date_time(context: _Context, p: _Problem) -> str:
    info = p.info
    example = _render(info.examples[0]) if info is not None and info.examples else "2026-11-23T15:00:00"
    return f"{p.where}: {p.value!r} is not a date-time; fix: write it as {example}"


def _wrong_type(context: _Context, p: _Problem) -> str:
    expected = _WRONG_TYPE[p.kind]
    fix = context.known_fix(p.loc, p.types) or (
        f"write it as {expected}, e.g. {_example(p.loc, p.info, p.types[-1])}{p.description}"
    )
    return f"{p.where}: must be {expected}, not {yaml_kind(p.value)}; fix: {fix}"


def _over_length(context: _Context, p: _Problem) -> str:
    limit = p.ctx.get("max_length")
    return (
        f"{p.where}: is {len(str(p.value))} characters, over the limit of {limit}; "
        f"fix: shorten it{p.description}"
    )


def _out_of_limits(context: _Context, p: _Problem) -> str:
    """A value outside a field's limits (or any other problem): pydantic's words, and the fix."""
    limit_fix = _LIMIT_FIXES.get(p.kind)
    fix = context.known_fix(p.loc, p.types) or (
        limit_fix(p.ctx) if limit_fix is not None else f"see {context.doc} for what this key accepts"
    )
    what = p.error["msg"].replace("Input should be", "must be").replace("String should", "must")
    return f"{p.where}: {what}, not {yaml_kind(p.value)}; fix: {fix}{p.description}"


def _wording(kind: str) -> Wording:
    """The wording of pydantic's error type ``kind``; date and time errors share one."""
    found = _WORDINGS.get(kind)
    if found is not None:
        return found
    return _not_a_date_time if kind.startswith(_DATE_TIME_KINDS) else _out_of_limits


_LIMIT_FIXES: dict[str, Callable[[dict[str, Any]], str]] = {
    "greater_than": lambda ctx: f"use a number greater than {ctx.get('gt')}",
    "greater_than_equal": lambda ctx: f"use a number of at least {ctx.get('ge')}",
    "less_than": lambda ctx: f"use a number less than {ctx.get('lt')}",
    "less_than_equal": lambda ctx: f"use a number of at most {ctx.get('le')}",
    "string_too_short": lambda ctx: "write a name; it must not be empty",
    "too_short": lambda ctx: f"list at least {ctx.get('min_length')} entries",
    "too_long": lambda ctx: f"list at most {ctx.get('max_length')} entries",
    "enum": lambda ctx: f"use one of {ctx.get('expected')}",
    "literal_error": lambda ctx: f"use one of {ctx.get('expected')}",
}
"""The fix for a value outside a field's limits, by pydantic's error type (from the error's ``ctx``)."""

_DATE_TIME_KINDS = ("datetime", "date_", "time_")
"""Prefixes of pydantic's error types for a value that is no date, time or date-time."""


# What a value of the wrong type should have been, by pydantic's error type.
_WRONG_TYPE = {
    "dict_type": "a mapping (key: value)",
    "model_type": "a mapping (key: value)",
    "model_attributes_type": "a mapping (key: value)",
    "list_type": "a list",
    "tuple_type": "a list",
    "set_type": "a list",
    "string_type": "text",
    "float_type": "a number",
    "float_parsing": "a number",
    "int_type": "a whole number",
    "int_parsing": "a whole number",
    "int_from_float": "a whole number",
    "finite_number": "a finite number",
    "bool_type": "true or false",
    "bool_parsing": "true or false",
}

_WORDINGS: dict[str, Wording] = {
    "extra_forbidden": _unknown_key,
    "missing": _missing,
    "too_long": _too_long,
    "value_error": _validator_message,
    "assertion_error": _validator_message,
    "string_too_long": _over_length,
    **dict.fromkeys(_WRONG_TYPE, _wrong_type),
}
"""How each of pydantic's error types is worded; the others: :func:`_wording`."""

# A value to show when the field names none, by the expected type.
_TYPE_EXAMPLES: dict[Any, str] = {
    float: "2.5",
    int: "3",
    bool: "true",
    str: "text",
    datetime.datetime: "2026-11-23T15:00:00",
}


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _is_model(annotation: Any) -> TypeGuard[type[BaseModel]]:
    from pydantic import BaseModel

    return isinstance(annotation, type) and issubclass(annotation, BaseModel)


def _unwrap(annotation: Any) -> Any:
    """``X | None`` -> ``X``; other unions stay."""
    args = [a for a in get_args(annotation) if a is not type(None)]
    if get_origin(annotation) in (Union, UnionType) and len(args) == 1:
        return args[0]
    return annotation


def _annotations(model: type[BaseModel], raw_loc: Location) -> tuple[list[Any], list[Any]]:
    """The location without pydantic's union tags, and the declared type at each of its prefixes.

    Types: [model, type at loc[:1], ..., type at loc], None where unknown. Pydantic names the
    member of a union it tried (``origin > tuple[float, float] > 1``); the reader gets ``origin > entry 2``.
    """
    out: list[Any] = [model]
    loc: list[Any] = []
    annotation: Any = model
    for part in raw_loc:
        annotation = _unwrap(annotation)
        origin = get_origin(annotation)
        members = {_type_name(a): a for a in get_args(annotation)} if origin in (Union, UnionType) else {}
        if isinstance(part, str) and part in members:
            annotation = members[part]
            out[-1] = annotation
            continue
        loc.append(part)
        if annotation is None:
            pass
        elif _is_model(annotation):
            info = annotation.model_fields.get(str(part))
            annotation = None if info is None else info.annotation
        elif origin is dict:
            annotation = get_args(annotation)[1]
        elif origin in (list, set, frozenset) or (origin is tuple and get_args(annotation)[-1:] == (...,)):
            annotation = get_args(annotation)[0]
        elif origin is tuple and isinstance(part, int) and part < len(get_args(annotation)):
            annotation = get_args(annotation)[part]
        else:
            annotation = None
        out.append(_unwrap(annotation))
    return out, loc


def _type_name(annotation: Any) -> str:
    """How pydantic names a union member in an error's location."""
    return annotation.__name__ if isinstance(annotation, type) else str(annotation)


def _field(types: list[Any], loc: Location) -> FieldInfo | None:
    parent = types[-2] if len(types) >= 2 else None
    if loc and _is_model(parent):
        return parent.model_fields.get(str(loc[-1]))
    return None


def _patterns(loc: Location, types: list[Any]) -> list[tuple[Any, ...]]:
    """The keys of ``loc`` in a fixes table, innermost model first (see :func:`describe_errors`)."""
    stars: list[Any] = []
    for i, part in enumerate(loc):
        stars.append(part if _is_model(types[i]) else "*")
    out: list[tuple[Any, ...]] = []
    for i in range(len(loc), -1, -1):
        if _is_model(types[i]):
            out.append((types[i], *[str(p) for p in stars[i:]]))
    out.append(tuple(str(p) for p in stars))
    return out


def _items(annotation: Any) -> str:
    args = [a for a in get_args(annotation) if a is not ...]
    return "numbers" if args and all(a in (float, int) for a in args) else "values"


def _expected(annotation: Any) -> tuple[str, str]:
    """What a container should be and an example of one."""
    origin = get_origin(annotation)
    if origin is tuple:
        args = [a for a in get_args(annotation) if a is not ...]
        return f"a list of {len(args)} {_items(annotation)}", _render([0.0] * len(args))
    if origin in (list, set):
        return "a list", "[a, b]"
    if origin is dict or _is_model(annotation):
        return "a mapping", "{key: value}"
    return "a value of the right type", "..."


def _example(loc: Location, info: FieldInfo | None, annotation: Any) -> str:
    """'connect: 2.0' from the field's examples or default, else from its type; '2.5' without a key."""
    from pydantic_core import PydanticUndefined

    value: Any = PydanticUndefined
    if info is not None and info.examples:
        value = info.examples[0]
    elif info is not None and info.default not in (PydanticUndefined, None):
        value = info.default
    text = _render(value) if value is not PydanticUndefined else _TYPE_EXAMPLES.get(annotation, "...")
    key = loc[-1] if loc else None
    return f"{key}: {text}" if isinstance(key, str) else text


def _render(value: Any) -> str:
    """A value as one would write it in YAML flow style: {a: 1, b: [x, y]}."""
    if isinstance(value, enum.Enum):
        value = value.value
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_render(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_render(v) for v in value) + "]"
    if isinstance(value, datetime.datetime | datetime.date):
        return value.isoformat()
    return str(value)
