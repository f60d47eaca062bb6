"""Run one part of the robot as its own process: a ROS node (``cyborg node NAME``).

Parts: ``cyborg_controller`` (state machine, emotion system and motivator, as in
the thesis), every module of the YAML's ``modules:`` section by its node name,
every gatekeeper by its name, and ``cyborg_api`` (the HTTP API and dashboard).
``cyborg launch`` starts them all, one process each.
"""

from __future__ import annotations

import logging
import random
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cyborg.app.config import LoadedConfig
from cyborg.app.kinds import MODULE_KINDS, parse_module_settings
from cyborg.app.robot import build_controller
from cyborg.controller.runtime import Controller
from cyborg.errors import ConfigError
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.transport.base import Transport

log = logging.getLogger(__name__)

CONTROLLER = "cyborg_controller"
API = "cyborg_api"


@dataclass
class NodeContext:
    """The BuildContext of one process."""

    data_dir: Path
    rng: random.Random
    map_path: Path | None = None
    calendar: Callable[[Any], None] | None = None
    resume: bool = True
    """The controller takes over an emotion stored recently (``cyborg node`` without ``--fresh``)."""
    _map: Any = field(default=None, repr=False)

    def occupancy_map(self) -> Any:
        if self._map is None:
            from cyborg.maps import default_map_path, load_map

            self._map = load_map(self.map_path or default_map_path())
        return self._map


def part_names(config: LoadedConfig) -> list[str]:
    """Every part ``cyborg node`` can run, in a sensible start order."""
    return [CONTROLLER, *config.model.modules, *(g.name for g in config.model.gatekeepers), API]


@dataclass
class Part:
    name: str
    components: list[object]
    controller: Controller | None = None
    stop: Callable[[], Any] | None = None


def build_part(name: str, config: LoadedConfig, transport: Transport, context: NodeContext) -> Part:
    """Build the components of part ``name`` on ``transport`` (not started)."""
    model = config.model
    if name == CONTROLLER:
        _, controller, emotion, motivator = build_controller(
            config, transport, context.data_dir, resume=context.resume
        )
        return Part(name, [controller, emotion, motivator], controller=controller)
    if name in model.modules:
        kind, settings = parse_module_settings(name, model.modules[name], MODULE_KINDS, config.source)
        return Part(name, [kind.build(transport.node(name), settings, context)])
    for gate in model.gatekeepers:
        if gate.name == name:
            keeper = Gatekeeper(
                transport.node(name), input_topic=gate.input, output_topic=gate.output, resource=gate.resource
            )
            return Part(name, [keeper])
    if name == API:
        return Part(name, [])  # built by the interface layer, which owns the HTTP server
    raise ConfigError(
        f"no part called {name!r}; fix: use one of {', '.join(part_names(config))}", source=config.source
    )
