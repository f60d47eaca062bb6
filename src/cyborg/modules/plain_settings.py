"""Settings a kind may write as a frozen stdlib dataclass, and how a node makes them without pydantic.

:class:`KindSettings` is what every kind's settings answer (pydantic's
:class:`~cyborg.modules.settings.ModuleSettings` derives from it too); :func:`setting` declares a
field with its description and pydantic ``Field`` constraints, checked where the configuration is
validated (:func:`cyborg.modules.settings.settings_model`); :func:`checked_settings` makes the
settings of a block validated already (by ``cyborg launch``) with the standard library alone.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from types import UnionType
from typing import Any, TypeVar, Union, get_args, get_origin, get_type_hints

__all__ = ["KindSettings", "checked_settings", "setting"]


def setting(default: Any = dataclasses.MISSING, *, description: str, **constraints: Any) -> Any:
    """A field of dataclass settings: its default, its ``description`` and pydantic ``Field``
    constraints (``gt=0``, ``min_length=1``...), checked wherever the configuration is validated."""
    return dataclasses.field(default=default, metadata={"description": description, **constraints})


class KindSettings:
    """What every kind's settings answer, known without starting the module (the defaults here).

    :class:`ModuleSettings` (a pydantic model) is one; a frozen stdlib dataclass deriving from
    it is another (see the module's doc).
    """

    __slots__ = ()

    def listens_for(self) -> tuple[str, ...]:
        """The phrases this module reacts to when speech-to-text hears them (lower case).

        Override it in a module that listens: ``cyborg validate`` warns when two modules
        listen for the same phrase (they would race for one sentence), and speech recognition
        adds the phrases to what it can hear. The default: none.
        """
        return ()

    def listens_for_places(self) -> tuple[str, ...]:
        """The phrases of :meth:`listens_for` that a place name follows ("where is" the cafeteria).

        Speech recognition puts the navigation database's places after them. The default: none.
        """
        return ()

    def publishes(self) -> tuple[str, ...]:
        """The events this module publishes (``publish_event``), known without starting it.

        Override it in a module that publishes events: ``cyborg validate`` warns about one that
        is no transition of any state (the controller would drop it). The default: none.
        """
        return ()

    def speaks_in(self) -> tuple[str, ...]:
        """The action servers (of :meth:`serves`) in whose states this module says things (``say``).

        Override it in a module that speaks: ``cyborg validate`` warns about such a state that
        does not grant the speech gatekeeper's resource to this module's node (its sentences
        would be dropped). The default: none.
        """
        return ()

    def serves(self) -> tuple[str, ...]:
        """The action servers this module offers (states' ``action:``), known without starting it.

        The default reads an ``action`` setting; a module that serves several states, or fixed
        ones, overrides it. ``cyborg validate`` warns about states that no module serves.
        """
        action = getattr(self, "action", None)
        return (action,) if isinstance(action, str) and action else ()


T = TypeVar("T", bound=KindSettings)


def checked_settings(cls: type[T], data: Mapping[str, Any]) -> T:
    """Dataclass settings ``cls`` from a block validated already (``cyborg launch`` checked the
    file through the kind's model), without pydantic: nested settings, tuples and numbers are
    made as the model's validation makes them; nothing else is checked here.

    A pydantic model (a plug-in's :class:`ModuleSettings`) is validated instead: it pays for it.
    """
    settings: Any = cls
    if not _is_dataclass(settings):
        return settings.model_validate(data)  # type: ignore[no-any-return]
    hints = get_type_hints(settings)
    values = {
        f.name: _made(hints[f.name], data[f.name]) for f in dataclasses.fields(settings) if f.name in data
    }
    return settings(**values)  # type: ignore[no-any-return]


def _is_dataclass(annotation: Any) -> bool:
    return isinstance(annotation, type) and dataclasses.is_dataclass(annotation)


_TRUE = frozenset({"1", "on", "t", "true", "y", "yes"})


def _made(annotation: Any, value: Any) -> Any:
    """``value`` (valid for ``annotation``) as pydantic's lax validation would make it."""
    if value is None:
        return None
    origin, args = get_origin(annotation), get_args(annotation)
    if origin in (Union, UnionType):
        members = [a for a in args if a is not type(None)]
        return _made(members[0], value) if len(members) == 1 else value
    if _is_dataclass(annotation) and isinstance(value, Mapping):
        return checked_settings(annotation, value)
    if origin is list:
        return [_made(args[0], item) for item in value]
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_made(args[0], item) for item in value)
        return tuple(_made(a, item) for a, item in zip(args, value, strict=False))
    if annotation is float and not isinstance(value, bool):
        return float(value)
    if annotation is int and not isinstance(value, bool):
        return int(float(value)) if isinstance(value, str) else int(value)
    if annotation is bool and not isinstance(value, bool):
        return bool(value) if isinstance(value, int | float) else value.strip().lower() in _TRUE
    return value
