"""Virtual time shared by a launch's processes: each node's clock, the shared origin, ``/clock``.

Simulated time (``--speed N``): every node runs a :class:`~cyborg.transport.clock.VirtualClock`
at speed N from one origin, so their virtual times agree. ``cyborg node --epoch T`` gives the
origin as a wall-clock time; ``cyborg launch --speed N`` starts the nodes with ``--epoch
param:NS`` (ROS 1; ROS 2: ``--epoch dir:FOLDER``) and, once every node is built and waiting,
fixes the origin in the parameter ``NS/epoch`` (the file ``FOLDER/epoch``): nodes take seconds to
start, so a time chosen in advance would be missed or wasted. The simulated base (the
controller when no base runs) publishes ``/clock`` from its clock ~10 times a real second, so
``rostopic``, ``rosbag`` and actionlib's timers follow the simulated time too.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from cyborg.errors import CyborgError
from cyborg.run.master import Master
from cyborg.transport.base import Publisher
from cyborg.transport.clock import DEFAULT_VIRTUAL_START, Clock, RealClock, VirtualClock
from cyborg.transport.lockstep import LockstepClock
from cyborg.transport.messages import Clock as ClockMessage
from cyborg.transport.topics import CONTROLLER_NODE as CONTROLLER

if TYPE_CHECKING:
    from cyborg.app.config import LoadedConfig
    from cyborg.app.sketch import PartConfig

__all__ = [
    "CLOCK_TOPIC",
    "FolderRendezvous",
    "MasterRendezvous",
    "Rendezvous",
    "SimTime",
    "check_virtual_time",
    "clock_owner_of",
    "is_simulated_base",
    "publish_clock",
    "wait_for_epoch",
]

CLOCK_TOPIC = "/clock"
CLOCK_RATE = 10.0  # /clock messages per real second
USE_SIM_TIME = "/use_sim_time"
SIM_PARAMS = "/cyborg_sim"  # a launch's shared-time parameters live under SIM_PARAMS/<run id>
EPOCH_PARAM_PREFIX = "param:"
EPOCH_DIR_PREFIX = "dir:"
EPOCH_MARGIN = 0.5  # real seconds between the last node being ready and virtual time starting
READY_TIMEOUT = 120.0  # real seconds a launch waits for its nodes to be ready


class Rendezvous(Protocol):
    """Where a launch's nodes say they are ready and read the origin of virtual time."""

    def mark_ready(self, name: str) -> None: ...
    def ready_names(self) -> set[str]: ...
    def set_epoch(self, epoch: float) -> None: ...
    def epoch(self) -> float | None: ...


class MasterRendezvous:
    """ROS 1: parameters under ``namespace`` on the master (``NS/ready/NAME``, ``NS/epoch``)."""

    def __init__(self, namespace: str, caller: str = "/cyborg_launch") -> None:
        self.namespace = namespace.rstrip("/")
        self.master = Master(caller=caller)

    def mark_ready(self, name: str) -> None:
        self.master.set(f"{self.namespace}/ready/{name}", True)

    def ready_names(self) -> set[str]:
        ready = self.master.get(f"{self.namespace}/ready", {})
        return {name for name, value in ready.items() if value} if isinstance(ready, dict) else set()

    def set_epoch(self, epoch: float) -> None:
        self.master.set(f"{self.namespace}/epoch", epoch)

    def epoch(self) -> float | None:
        epoch = self.master.get(f"{self.namespace}/epoch")
        return float(epoch) if isinstance(epoch, int | float) and not isinstance(epoch, bool) else None


class FolderRendezvous:
    """ROS 2 (no master): files in ``folder``, ``ready/NAME`` and ``epoch`` (written whole, then renamed)."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    def mark_ready(self, name: str) -> None:
        (self.folder / "ready").mkdir(parents=True, exist_ok=True)
        (self.folder / "ready" / name).touch()

    def ready_names(self) -> set[str]:
        folder = self.folder / "ready"
        return {path.name for path in folder.iterdir()} if folder.is_dir() else set()

    def set_epoch(self, epoch: float) -> None:
        partial = self.folder / "epoch.partial"
        partial.write_text(repr(epoch), encoding="utf-8")
        partial.replace(self.folder / "epoch")

    def epoch(self) -> float | None:
        try:
            return float((self.folder / "epoch").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None


@dataclass(frozen=True)
class SimTime:
    """How a node keeps time: real time, or virtual time at ``speed`` from a shared origin.

    ``epoch``: the wall-clock time (Unix seconds) at which virtual time reads ``start``; or
    ``param:NS`` (ROS 1) / ``dir:FOLDER`` (ROS 2), to wait for the launch to set ``NS/epoch``
    (``FOLDER/epoch``) once every node is ready; or None: the moment the node starts.
    """

    speed: float | None = None
    epoch: float | str | None = None
    start: datetime = DEFAULT_VIRTUAL_START
    lockstep: str | None = None
    """``HOST:PORT`` of the launch's lockstep time server: virtual time as fast as the whole graph
    allows, granted by it (:mod:`cyborg.run.lockstep`); excludes ``speed`` and ``epoch``."""

    @property
    def virtual(self) -> bool:
        return self.speed is not None or self.lockstep is not None

    @property
    def rendezvous(self) -> Rendezvous | None:
        """Where the launch sets the origin, when it does."""
        if isinstance(self.epoch, str) and self.epoch.startswith(EPOCH_PARAM_PREFIX):
            return MasterRendezvous(
                self.epoch[len(EPOCH_PARAM_PREFIX) :], caller=f"/cyborg_node_{os.getpid()}"
            )
        if isinstance(self.epoch, str) and self.epoch.startswith(EPOCH_DIR_PREFIX):
            return FolderRendezvous(Path(self.epoch[len(EPOCH_DIR_PREFIX) :]))
        return None

    def make_clock(self) -> Clock:
        if self.lockstep is not None:
            if self.speed is not None or self.epoch is not None:
                raise CyborgError(
                    "--lockstep runs as fast as the graph allows, at no speed and with no origin; "
                    "fix: drop --speed and --epoch"
                )
            return LockstepClock(self.lockstep, self.start)
        if self.speed is None:
            if self.epoch is not None:
                raise CyborgError("--epoch goes with --speed: real time needs no shared origin")
            return RealClock()
        if isinstance(self.epoch, str):
            origin = math.inf  # stands still until the launch fixes the origin
        elif self.epoch is None:
            origin = time.time()
        else:
            origin = float(self.epoch)
        return VirtualClock(self.start, self.speed, real_origin=origin)


async def publish_clock(publisher: Publisher[ClockMessage], clock: VirtualClock) -> None:
    """Publish ``clock``'s time on /clock about CLOCK_RATE times a real second, for ever."""
    assert clock.speed is not None
    step = clock.speed / CLOCK_RATE
    while True:
        publisher.publish(ClockMessage(clock.now()))
        await clock.sleep(step)


def is_simulated_base(config: PartConfig, name: str) -> bool:
    raw = config.model.modules.get(name)
    return isinstance(raw, dict) and raw.get("kind") == "simulated_base"


def check_virtual_time(config: LoadedConfig) -> None:
    """Refuse virtual time for a configuration that drives a real base: the navigation module's
    base moves in real time, and no simulated base serves its names."""
    modules = config.model.modules.values()
    kinds = {raw.get("kind") for raw in modules if isinstance(raw, dict)}
    if "navigation" in kinds and "simulated_base" not in kinds:
        raise CyborgError(
            f"{config.source}: --speed runs virtual time, but this configuration drives a real base "
            "(a navigation module and no simulated_base): a real robot moves in real time; fix: drop "
            "--speed, or use a configuration with a simulated base (the packaged cyborg.yaml)"
        )


def clock_owner_of(config: LoadedConfig, parts: Sequence[str]) -> str:
    """The part that publishes /clock: the simulated base, else the controller, else the first."""
    for name in parts:
        if is_simulated_base(config, name):
            return name
    return CONTROLLER if CONTROLLER in parts else parts[0]


def wait_for_epoch(rendezvous: Rendezvous, name: str) -> float:
    """Report this node ready and wait for the launch to fix the origin."""
    rendezvous.mark_ready(name)
    deadline = time.monotonic() + READY_TIMEOUT + 30
    while True:
        epoch = rendezvous.epoch()
        if epoch is not None:
            return epoch
        if time.monotonic() > deadline:
            raise CyborgError(
                "no origin of virtual time appeared (the launch sets it once every node is ready); "
                "fix: start this node with `cyborg launch --speed N`, or give it --epoch UNIX_SECONDS"
            )
        time.sleep(0.05)
