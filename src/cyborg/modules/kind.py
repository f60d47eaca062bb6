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

import random
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Generic, Protocol, TypeVar, runtime_checkable

from cyborg.modules.plain_settings import KindSettings, checked_settings, setting
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
