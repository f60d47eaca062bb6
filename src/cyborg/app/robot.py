"""Assemble a robot from a configuration: the controller plus its modules.

This is where the layers meet: it builds the controller and every module the
YAML's ``modules:`` section names, on one transport and one clock. ``cyborg
sim`` runs the result; tests build it on a virtual clock.
"""

from __future__ import annotations

import logging
import random
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cyborg.app.config import LoadedConfig
from cyborg.app.kinds import MODULE_KINDS, ModuleKind, parse_module_settings
from cyborg.controller.runtime import Controller, Phase
from cyborg.emotion.system import EmotionSystem
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.motivator.component import Motivator
from cyborg.motivator.store import ControllerStore
from cyborg.transport.base import Transport

log = logging.getLogger(__name__)


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
    rng: random.Random
    map_path: Path | None = None
    components: dict[str, object] = field(default_factory=dict)
    calendar: Callable[[Any], None] | None = None  # set by the navigation module: adds a calendar entry

    _map: Any = None

    def occupancy_map(self) -> Any:
        """The map of the simulated world (``--map`` or the packaged campus), loaded once."""
        if self._map is None:
            from cyborg.maps import default_map_path, load_map

            self._map = load_map(self.map_path or default_map_path())
        return self._map

    def start(self) -> None:
        self.controller.start()

    def close(self) -> None:
        """Stop the periodic work of the modules, the motivator and the emotion system, then close
        the store (it makes a last try to write what a failing disk left in memory)."""
        for component in self.components.values():
            close = getattr(component, "close", None)
            if callable(close):
                close()
        self.motivator.close()
        self.emotion.close()
        self.store.close()


def build_controller(
    config: LoadedConfig, transport: Transport, data_dir: Path, *, resume: bool = False
) -> tuple[ControllerStore, Controller, EmotionSystem, Motivator]:
    """The thesis's ``cyborg_controller``: state machine, emotion system and motivator, with their store.

    A fresh start (the default) is neutral with the emotion system on and the motivator's
    saturations at 0, whatever ``data_dir`` holds. ``resume`` (a controller brought back after
    a crash while the rest of the robot runs on) takes over the stored emotion, switch and
    saturations if they were stored within the emotion's ``resume_within_seconds``.
    """
    data_dir.mkdir(parents=True, exist_ok=True)
    settings = config.model
    store = ControllerStore(
        data_dir / "controller.db", seed_events=settings.motivator.events, clock=transport.clock
    )
    for entry in settings.motivator.events:
        store.add_event(entry)  # the YAML is the source; entries added to the database stay too
    controller = Controller(transport.node("cyborg_controller"), config.machine)
    emotion = EmotionSystem(transport.node("cyborg_emotion"), settings.emotion, store, resume=resume)
    if not emotion.resumed:
        store.save_saturations({})
    motivator = Motivator(
        transport.node("cyborg_motivator"),
        settings.motivator,
        config.machine,
        store,
        controller_busy=controller_busy(controller),
    )
    return store, controller, emotion, motivator


def build_robot(
    config: LoadedConfig,
    transport: Transport,
    *,
    data_dir: Path,
    rng: random.Random | None = None,
    map_path: Path | None = None,
    kinds: dict[str, ModuleKind] | None = None,
) -> Robot:
    """Create the controller (state machine, emotion system, motivator) and the configured modules.

    ``data_dir`` holds the databases (created on first use). Nothing runs until ``start()``.
    """
    factories = {**MODULE_KINDS, **(kinds or {})}
    settings = config.model
    store, controller, emotion, motivator = build_controller(config, transport, data_dir)
    robot = Robot(
        transport=transport,
        config=config,
        controller=controller,
        emotion=emotion,
        motivator=motivator,
        store=store,
        data_dir=data_dir,
        rng=rng or random.Random(0),
        map_path=map_path,
    )
    for name, raw in config.model.modules.items():
        kind, module_settings = parse_module_settings(name, raw, factories, config.source)
        robot.components[name] = kind.build(transport.node(name), module_settings, robot)
    for gate in settings.gatekeepers:
        robot.components[gate.name] = Gatekeeper(
            transport.node(gate.name),
            input_topic=gate.input,
            output_topic=gate.output,
            resource=gate.resource,
        )
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


def controller_busy(controller: Controller) -> Callable[[], bool]:
    """A check for :class:`Motivator`: true unless ``controller`` is running a module that has not finished.

    It covers what the event topic does not show: the cancel wait, entering a state, and a
    module's result (succeeded / aborted) that is about to become a handover.
    """

    def busy() -> bool:
        status = controller.goal_status
        return controller.phase is not Phase.ACTIVE or (status is not None and status.is_terminal)

    return busy
