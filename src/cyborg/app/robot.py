"""Build the in-process robot from its configuration: the controller trio plus its modules.

Every part runs on one transport and one clock: the controller, emotion system and
motivator with their store (:func:`build_controller`), each module of the YAML's
``modules:`` section (its kind found in the :class:`~cyborg.app.registry.KindRegistry`)
and each gatekeeper. ``cyborg sim`` runs the result; tests build it on a virtual clock.
The ROS nodes are built from the same pieces, one part per process (:mod:`cyborg.app.parts`).
"""

from __future__ import annotations

import asyncio
import logging
import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cyborg.app.config import LoadedConfig
from cyborg.app.context import BuildContext, calendar_of, heard_by, relays_of
from cyborg.app.registry import KindRegistry, build_module, module_kinds
from cyborg.app.tuning import freeze_built, thaw
from cyborg.app.view import BaseView
from cyborg.controller.runtime import Controller, Phase
from cyborg.emotion.system import EmotionSystem
from cyborg.modules.gatekeeper import Gatekeeper
from cyborg.modules.kind import Component, Listening, ServesStates
from cyborg.motivator.component import Motivator
from cyborg.motivator.store import COMMIT_WINDOW, ControllerStore
from cyborg.navigation.calendar import CalendarEntry
from cyborg.storage import SaveStatus
from cyborg.transport.base import Transport
from cyborg.transport.watchdog import LoopWatchdog

if TYPE_CHECKING:
    from cyborg.maps import OccupancyMap

log = logging.getLogger(__name__)

__all__ = ["BuildContext", "Robot", "build_controller", "build_gatekeeper", "build_robot", "controller_busy"]


@dataclass
class Robot:
    """Everything running on one transport: the controller trio, the modules and the gatekeepers."""

    transport: Transport
    config: LoadedConfig
    controller: Controller
    emotion: EmotionSystem
    motivator: Motivator
    store: ControllerStore
    place: BuildContext
    components: dict[str, Component] = field(default_factory=dict)
    """Modules and gatekeepers by node name."""
    watchdog: LoopWatchdog | None = None
    """Names a callback that blocks the shared event loop (from :meth:`start` on, in real time)."""

    @property
    def data_dir(self) -> Path:
        return self.place.data_dir

    @property
    def rng(self) -> random.Random:
        return self.place.rng

    def occupancy_map(self) -> OccupancyMap:
        return self.place.occupancy_map()

    def listening(self) -> Listening:
        return self.place.listening()

    @property
    def calendar(self) -> Callable[[CalendarEntry], None] | None:
        """Adds a calendar entry to the module that keeps the calendar (None if none does)."""
        return calendar_of(self.components.values())

    def start(self) -> None:
        """Start the controller; what the build made is frozen out of garbage collections from now
        on (:mod:`cyborg.app.tuning`), so none walks the whole machine on the controller's loop."""
        freeze_built()
        clock = self.transport.clock
        if not clock.is_virtual:  # where people wait on it (virtual runs stay as they were)
            # It also keeps the controller's handover deadlines: a module's call that holds the loop
            # past one is stopped (the controller's own code, the emotion system and the motivator never).
            self.watchdog = LoopWatchdog(
                clock.loop,
                now=clock.loop.time,
                deadline=lambda: self.controller.deadline,
                stoppable=self.components.__contains__,
            )
            self.watchdog.start()
        self.controller.start()

    # --- the RobotView the dashboard reads (cyborg.app.view) --------------------------------

    def emotion_enabled(self) -> bool:
        return self.emotion.enabled

    def save_status(self) -> SaveStatus:
        return self.store.save_status

    def loop_blocked(self) -> dict[str, Any] | None:
        return self.watchdog.report() if self.watchdog is not None else None

    def base(self) -> BaseView | None:
        for component in self.components.values():
            if isinstance(component, BaseView):
                return component
        return None

    def module_actions(self) -> dict[str, list[str]]:
        return {
            name: sorted(action.lstrip("/") for action in component.servers)
            if isinstance(component, ServesStates)
            else []
            for name, component in self.components.items()
        }

    def close(self) -> None:
        """Close every component (modules, gatekeepers, then the controller trio), shut their
        nodes down, and close the store (it makes a last try to write what a failing disk left)."""
        trio: list[Component] = [self.motivator, self.emotion, self.controller]
        for component in [*self.components.values(), *trio]:
            try:
                component.close()
            except Exception:
                log.exception("closing %s failed; closing the rest", component.node.name)
            component.node.shutdown()
        self.store.close()
        if self.watchdog is not None:
            self.watchdog.stop()
        thaw()


def served_actions(components: Iterable[object]) -> set[str]:
    """The action names (without leading slash) the components serve."""
    return {name.lstrip("/") for c in components if isinstance(c, ServesStates) for name in c.servers}


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
        data_dir / "controller.db",
        seed_events=settings.motivator.events,
        clock=transport.clock,
        write_behind=True,
        # A simulated day saves the emotion thousands of times a real second: commit them together.
        commit_window=COMMIT_WINDOW if transport.clock.as_fast_as_possible else 0.0,
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


def build_gatekeeper(config: LoadedConfig, transport: Transport, name: str) -> Gatekeeper | None:
    """The gatekeeper called ``name`` of ``config`` on its own node, or None if there is none."""
    for gate in config.model.gatekeepers:
        if gate.name == name:
            return Gatekeeper(
                transport.node(name), input_topic=gate.input, output_topic=gate.output, resource=gate.resource
            )
    return None


def build_robot(
    config: LoadedConfig,
    transport: Transport,
    *,
    data_dir: Path,
    seed: int = 0,
    map_path: Path | None = None,
    kinds: KindRegistry | None = None,
) -> Robot:
    """Create the controller (state machine, emotion system, motivator), the configured modules and
    the gatekeepers. ``kinds`` defaults to every installed kind (:func:`module_kinds`).

    ``data_dir`` holds the databases (created on first use). Nothing runs until ``start()``.
    """
    registry = kinds or module_kinds()
    store, controller, emotion, motivator = build_controller(config, transport, data_dir)
    place = BuildContext(
        data_dir=data_dir,
        seed=seed,
        map_path=map_path,
        heard=heard_by(config, registry),
        relays=relays_of(config),
    )
    robot = Robot(transport, config, controller, emotion, motivator, store, place)
    try:
        for name, raw in config.model.modules.items():
            kind, settings = registry.parse(name, raw, source=config.source)
            robot.components[name] = build_module(
                name,
                kind,
                transport.node(name),
                settings,
                place.for_module(name),
                source=config.source,
                where=config.where("modules", name),
            )
        for gate in config.model.gatekeepers:
            keeper = build_gatekeeper(config, transport, gate.name)
            assert keeper is not None
            robot.components[gate.name] = keeper
    except BaseException:
        robot.close()  # what was built so far: no timer or database left open
        _finish_cancelled(transport)
        raise
    warn_unserved(config, served_actions(robot.components.values()))
    return robot


def _finish_cancelled(transport: Transport) -> None:
    """Let the tasks that closing a half-built robot cancelled finish, when no loop runs yet (``cyborg
    sim`` builds before it runs): otherwise asyncio reports them as destroyed while pending."""
    loop = transport.clock.loop
    if not loop.is_running() and not loop.is_closed():
        pending = [task for task in asyncio.all_tasks(loop) if task.cancelled() or task.cancelling()]
        if pending:
            loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))


def warn_unserved(config: LoadedConfig, served: set[str]) -> None:
    """Log each state whose action no configured module serves (an external module may)."""
    for leaf in config.machine.leaves():
        assert leaf.action is not None
        if leaf.action.lstrip("/") not in served:
            log.warning(
                "no configured module serves %s (state %s): the controller will take 'aborted' "
                "unless an external module offers it",
                leaf.action,
                leaf.name,
            )


def controller_busy(controller: Controller) -> Callable[[], bool]:
    """A check for :class:`Motivator`: true unless ``controller`` is running a module that has not finished.

    It covers what the event topic does not show: the cancel wait, entering a state, and a
    module's result (succeeded / aborted) that is about to become a handover.
    """

    def busy() -> bool:
        status = controller.goal_status
        return controller.phase is not Phase.ACTIVE or (status is not None and status.is_terminal)

    return busy
