"""Assemble a robot from a configuration: the controller plus its modules.

This is where the layers meet: it builds the controller and every module the
YAML's ``modules:`` section names, on one transport and one clock. ``cyborg
sim`` runs the result; tests build it on a virtual clock.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cyborg.controller.config import LoadedConfig
from cyborg.controller.runtime import Controller
from cyborg.emotion.store import ControllerStore
from cyborg.emotion.system import EmotionSystem
from cyborg.errors import ConfigError
from cyborg.modules.event_script import EventScript
from cyborg.modules.idle import IdleModule, IdleSettings
from cyborg.modules.placeholder import PlaceholderModule, PlaceholderSpec
from cyborg.motivator.component import Motivator
from cyborg.transport.base import Node, Transport

log = logging.getLogger(__name__)

ModuleFactory = Callable[[Node, dict[str, Any], "Robot"], object]


@dataclass
class Robot:
    """Everything running on one transport."""

    transport: Transport
    config: LoadedConfig
    controller: Controller
    emotion: EmotionSystem
    motivator: Motivator
    store: ControllerStore
    data_dir: Path
    components: dict[str, object] = field(default_factory=dict)

    def start(self) -> None:
        self.controller.start()


def _placeholder(node: Node, settings: dict[str, Any], robot: Robot) -> object:
    servers = settings.get("servers")
    if not isinstance(servers, list) or not servers:
        raise ConfigError(
            f"module {node.name!r}: a placeholder needs 'servers:', a list of "
            "{action: ..., say: ..., duration: ...}; fix: add at least one server"
        )
    specs = []
    for entry in servers:
        unknown = set(entry) - {"action", "say", "duration", "emotion", "honour_cancel"}
        if unknown or "action" not in entry:
            raise ConfigError(
                f"module {node.name!r}: server entry {entry!r} is invalid; fix: use the keys "
                "action (required), say, duration, emotion [p, a, d], honour_cancel"
            )
        emotion = entry.get("emotion")
        specs.append(
            PlaceholderSpec(
                action=str(entry["action"]),
                say=str(entry.get("say", "")),
                duration=None if entry.get("duration") is None else float(entry["duration"]),
                emotion=tuple(emotion) if emotion else None,  # type: ignore[arg-type]
                honour_cancel=bool(entry.get("honour_cancel", True)),
            )
        )
    return PlaceholderModule(node, specs)


def _event_script(node: Node, settings: dict[str, Any], robot: Robot) -> object:
    events = settings.get("events")
    if not isinstance(events, list) or not all(isinstance(e, str) for e in events):
        raise ConfigError(
            f"module {node.name!r}: 'events' must be a list of event names; fix: e.g. events: [music_play]"
        )
    return EventScript(node, events, float(settings.get("every", 10.0)))


def _idle(node: Node, settings: dict[str, Any], robot: Robot) -> object:
    unknown = set(settings) - {"kind", "interval", "boredom", "action"}
    if unknown:
        raise ConfigError(
            f"module {node.name!r}: unknown keys {sorted(unknown)}; fix: use interval, boredom [p, a, d], action"
        )
    defaults = IdleSettings()
    boredom = settings.get("boredom", defaults.boredom)
    if not (isinstance(boredom, list | tuple) and len(boredom) == 3):
        raise ConfigError(f"module {node.name!r}: boredom must be [p, a, d], got {boredom!r}")
    idle = IdleSettings(
        interval=float(settings.get("interval", defaults.interval)),
        boredom=(float(boredom[0]), float(boredom[1]), float(boredom[2])),
    )  # type: ignore[arg-type]
    return IdleModule(node, idle, action=str(settings.get("action", "cyborg_idle/idle")))


MODULE_KINDS: dict[str, ModuleFactory] = {
    "placeholder": _placeholder,
    "event_script": _event_script,
    "idle": _idle,
}


def build_robot(
    config: LoadedConfig,
    transport: Transport,
    *,
    data_dir: Path,
    kinds: dict[str, ModuleFactory] | None = None,
) -> Robot:
    """Create the controller (state machine, emotion system, motivator) and the configured modules.

    ``data_dir`` holds the databases (created on first use). Nothing runs until ``start()``.
    """
    factories = {**MODULE_KINDS, **(kinds or {})}
    data_dir.mkdir(parents=True, exist_ok=True)
    settings = config.model
    store = ControllerStore(data_dir / "controller.db", seed_events=settings.motivator.events)
    for entry in settings.motivator.events:
        store.add_event(entry)  # the YAML is the source; entries added to the database stay too
    controller = Controller(transport.node("cyborg_controller"), config.machine)
    emotion = EmotionSystem(transport.node("cyborg_emotion"), settings.emotion, store)
    motivator = Motivator(transport.node("cyborg_motivator"), settings.motivator, config.machine, store)
    robot = Robot(
        transport=transport,
        config=config,
        controller=controller,
        emotion=emotion,
        motivator=motivator,
        store=store,
        data_dir=data_dir,
    )
    for node_name, settings in config.model.modules.items():
        kind = settings.get("kind", "placeholder") if isinstance(settings, dict) else None
        factory = factories.get(str(kind))
        if factory is None:
            raise ConfigError(
                f"module {node_name!r}: unknown kind {kind!r}; fix: use one of {', '.join(sorted(factories))}",
                source=config.source,
            )
        robot.components[node_name] = factory(transport.node(node_name), settings, robot)
    served = _served_actions(robot)
    for leaf in config.machine.leaves():
        assert leaf.action is not None
        if leaf.action.lstrip("/") not in served:
            log.warning(
                "no configured module serves %s (state %s): the controller will take 'aborted' "
                "unless an external module offers it",
                leaf.action,
                leaf.name,
            )
    return robot


def _served_actions(robot: Robot) -> set[str]:
    served: set[str] = set()
    for component in robot.components.values():
        servers = getattr(component, "servers", {})
        served.update(name.lstrip("/") for name in servers)
    return served
