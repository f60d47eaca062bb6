"""What a module kind is: its settings, its factory, and the contract of what it builds.

A *kind* is what a block of the YAML's ``modules:`` section names with ``kind:``; how one is
registered and found: ``docs/modules.md``, "How a kind is found".

The composition root (:mod:`cyborg.app`) validates a block against ``settings``, then calls
``build`` with the module's own node, the validated settings and a :class:`BuildContext`.

``settings`` is a pydantic model (:class:`ModuleSettings`, what a plug-in writes) or a frozen
stdlib dataclass of :class:`KindSettings` whose fields carry pydantic's ``Field`` arguments in
their ``metadata`` (the built-in thin kinds): validated through a model made from it where a
configuration is checked (:func:`cyborg.modules.settings.settings_model`), and built without
pydantic by a node the launch checked its file for (:func:`checked_settings`), so such a node
loads no pydantic (issue 33). :class:`ModuleSettings` itself is imported when first used.
"""

from __future__ import annotations

import dataclasses
import random
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import UnionType
from typing import (
    TYPE_CHECKING,
    Any,
    Generic,
    Protocol,
    TypeVar,
    Union,
    get_args,
    get_origin,
    get_type_hints,
    runtime_checkable,
)

from cyborg.transport.base import Node
from cyborg.transport.topics import BaseApi

if TYPE_CHECKING:
    from cyborg.maps import OccupancyMap
    from cyborg.modules.settings import ModuleSettings

__all__ = [
    "BuildContext",
    "Component",
    "KindSettings",
    "Listening",
    "ModuleKind",
    "ModuleSettings",
    "ServesStates",
    "checked_settings",
    "listening_of",
    "setting",
]


def __getattr__(name: str) -> Any:
    if name == "ModuleSettings":  # pydantic's: imported by the first module that uses it
        from cyborg.modules.settings import ModuleSettings

        return ModuleSettings
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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


@dataclass(frozen=True)
class Listening:
    """What the robot's modules listen for in speech: phrases said on their own, and phrases a place follows."""

    phrases: tuple[str, ...] = ()
    place_phrases: tuple[str, ...] = ()


def listening_of(settings: Iterable[KindSettings]) -> Listening:
    """What the modules with ``settings`` listen for, together (lower case, each phrase once)."""
    modules = list(settings)
    places = dict.fromkeys(p.strip().lower() for s in modules for p in s.listens_for_places())
    alone = dict.fromkeys(p.strip().lower() for s in modules for p in s.listens_for())
    return Listening(tuple(p for p in alone if p not in places), tuple(places))


@runtime_checkable
class Component(Protocol):
    """A running part of the robot: it works on its own node and can be closed.

    ``close()`` stops its periodic work and the goals it runs; the robot shuts the
    node down afterwards (withdrawing its topics, services and action servers).
    """

    node: Node

    def close(self) -> None: ...


@runtime_checkable
class ServesStates(Protocol):
    """A component that serves states of the machine: ``servers`` maps action names to servers."""

    @property
    def servers(self) -> Mapping[str, object]: ...


class BuildContext(Protocol):
    """What a factory may use besides its node and settings."""

    @property
    def data_dir(self) -> Path:
        """The robot's data folder (databases, generated files)."""
        ...

    @property
    def rng(self) -> random.Random:
        """The robot's random source: seeded, so a simulated run repeats."""
        ...

    def occupancy_map(self) -> OccupancyMap:
        """The map of the world the robot is in (``--map``, or the packaged one), loaded once."""
        ...

    def listening(self) -> Listening:
        """What every module of the robot's configuration listens for in speech (its ears' grammar)."""
        ...

    def relays_to(self, topic: str) -> tuple[str, ...] | None:
        """The gatekeepers (node names) the configuration puts in front of ``topic``: the only
        nodes an output module on ``topic`` should take messages from (empty: none; None: built
        without a configuration)."""
        ...

    @property
    def base_api(self) -> BaseApi:
        """The robot base's interface on this graph (ROSARNL's, or nav2's on ROS 2), unless a
        module's settings name one."""
        ...


S = TypeVar("S", bound=KindSettings)


@dataclass(frozen=True)
class ModuleKind(Generic[S]):
    """A module kind: the settings model of its YAML block and the factory of its component."""

    settings: type[S]
    build: Callable[[Node, S, BuildContext], Component]

    @property
    def summary(self) -> str:
        """The first line of the settings model's docstring: what the kind does."""
        doc = (self.settings.__doc__ or "").strip()
        return doc.splitlines()[0] if doc else ""


def checked_settings(cls: type[S], data: Mapping[str, Any]) -> S:
    """Dataclass settings ``cls`` from a block validated already (``cyborg launch`` checked the
    file through the kind's model), without pydantic: nested settings, tuples and numbers are
    made as the model's validation makes them; nothing else is checked here.

    A pydantic model (a plug-in's :class:`ModuleSettings`) is validated instead: it pays for it.
    """
    if not dataclasses.is_dataclass(cls):
        return cls.model_validate(data)  # type: ignore[attr-defined,no-any-return]
    hints = get_type_hints(cls)
    values = {f.name: _made(hints[f.name], data[f.name]) for f in dataclasses.fields(cls) if f.name in data}
    return cls(**values)


_TRUE = frozenset({"1", "on", "t", "true", "y", "yes"})


def _made(annotation: Any, value: Any) -> Any:
    """``value`` (valid for ``annotation``) as pydantic's lax validation would make it."""
    if value is None:
        return None
    origin, args = get_origin(annotation), get_args(annotation)
    if origin in (Union, UnionType):
        members = [a for a in args if a is not type(None)]
        return _made(members[0], value) if len(members) == 1 else value
    if isinstance(annotation, type) and dataclasses.is_dataclass(annotation) and isinstance(value, Mapping):
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
        return str(value).strip().lower() in _TRUE
    return value
