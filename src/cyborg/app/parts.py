"""Build one part of the robot for its own process: a ROS node (``cyborg node NAME``).

Parts: ``cyborg_controller`` (state machine, emotion system and motivator, as in
the thesis), every module of the YAML's ``modules:`` section by its node name,
every gatekeeper by its name, ``cyborg_recorder`` (the flight recorder, unless the configuration's
``recording`` is off) and ``cyborg_api`` (the HTTP API and dashboard).
``cyborg launch`` starts them all, one process each. A part is built from the same
pieces as the in-process robot (:mod:`cyborg.app.robot`), and a module's part imports
only its own kind: a module's or gatekeeper's part reads the configuration as a
:class:`~cyborg.app.sketch.PartConfig` (a sketch of it when the launch validated it), and only the
controller's part imports the controller, the emotion system and the motivator.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from cyborg.app.context import BuildContext, calendar_of, heard_by, relays_of
from cyborg.app.registry import KindRegistry, build_module, module_kinds
from cyborg.app.sketch import ConfigSketch, PartConfig
from cyborg.errors import ConfigError, CyborgError
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.modules.kind import Component
from cyborg.navigation.calendar import CalendarEntry
from cyborg.transport import topics
from cyborg.transport.base import Transport

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig
    from cyborg.controller.runtime import Controller

__all__ = ["API", "CONTROLLER", "RECORDER", "SCENARIO", "Part", "build_part", "part_names"]

CONTROLLER = topics.CONTROLLER_NODE
API = "cyborg_api"
RECORDER = "cyborg_recorder"
SCENARIO = "cyborg_scenario"
"""The node that plays a scenario script over ROS (:mod:`cyborg.run.scenario`); not a part of the robot."""


def part_names(config: PartConfig) -> list[str]:
    """Every part ``cyborg node`` can run, in a sensible start order (the recorder before the
    robot's modules, so that it hears them from the start)."""
    recorder = [RECORDER] if config.model.recording.enabled else []
    return [CONTROLLER, *recorder, *config.model.modules, *(g.name for g in config.model.gatekeepers), API]


@dataclass
class Part:
    """The components of one process; the controller's is also in ``controller``."""

    name: str
    components: list[Component] = field(default_factory=list)
    controller: Controller | None = None
    stop: Callable[[], Any] | None = None

    @property
    def calendar(self) -> Callable[[CalendarEntry], None] | None:
        """Adds a calendar entry to this part's module that keeps the calendar, if any."""
        return calendar_of(self.components)

    def close(self) -> None:
        """Close every component and shut its node down."""
        for component in self.components:
            component.close()
            component.node.shutdown()


def build_part(
    name: str,
    config: LoadedConfig | PartConfig,
    transport: Transport,
    context: BuildContext,
    *,
    kinds: KindRegistry | None = None,
) -> Part:
    """Build the components of part ``name`` on ``transport`` (not started)."""
    model = config.model
    if name == CONTROLLER:
        from cyborg.app.config import LoadedConfig
        from cyborg.app.robot import build_controller

        if not isinstance(config, LoadedConfig):
            raise CyborgError(f"{CONTROLLER} builds from the validated configuration, not a sketch of it")
        _, controller, emotion, motivator = build_controller(
            config, transport, context.data_dir, resume=context.resume
        )
        return Part(name, [controller, emotion, motivator], controller=controller)
    if name in model.modules:
        registry = kinds or module_kinds()
        # a sketch's file was validated by the launch: its kind's settings are made, not validated again
        parse = registry.parse_checked if isinstance(config, ConfigSketch) else registry.parse
        kind, settings = parse(name, model.modules[name], source=config.source)
        if context.relays is None:
            context.relays = relays_of(config)
        if context.heard is None:  # only a module that asks (speech input) imports the other kinds
            context.heard = heard_by(config, registry)
        module = build_module(
            name,
            kind,
            transport.node(name),
            settings,
            context.for_module(name),
            source=config.source,
            where=config.where("modules", name),
        )
        return Part(name, [module])
    for gate in model.gatekeepers:
        if gate.name == name:  # as cyborg.app.robot's, without importing the whole robot
            keeper = Gatekeeper(
                transport.node(name), input_topic=gate.input, output_topic=gate.output, resource=gate.resource
            )
            return Part(name, [keeper])
    if name == API:
        return Part(name, [])  # built by the interface layer, which owns the HTTP server
    if name == RECORDER:
        return Part(name, [])  # built where the node runs (cyborg.run.node): the recorder is observe's
    raise ConfigError(
        f"no part called {name!r}; fix: use one of {', '.join(part_names(config))}", source=config.source
    )
