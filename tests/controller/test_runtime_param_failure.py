"""A parameter the controller cannot set does not stop it (issue 12, item 3): it logs the failure
and enters the state anyway; an error that does stop its loop is logged, not lost."""

from __future__ import annotations

import logging
from typing import Any

import pytest

from cyborg.app.config import parse_config
from cyborg.controller.runtime import Controller
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from tests.controller.test_runtime import MACHINE, Modules, Recorder


def test_a_failing_set_param_is_logged_and_the_state_is_entered_anyway(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
    transport = EmbeddedTransport(clock)
    Modules(transport)
    recorder = Recorder(transport)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)

    def set_param(name: str, value: Any) -> None:
        raise ConnectionRefusedError(111, "Connection refused")

    controller.node.set_param = set_param  # type: ignore[method-assign]
    task = controller.start()

    async def main() -> None:
        await clock.sleep(1.0)
        recorder.send("tell")
        await clock.sleep(1.0)

    with caplog.at_level(logging.ERROR, logger="cyborg.controller.runtime"):
        clock.run(main())
    assert recorder.changes == [("", "start", "idle"), ("idle", "tell", "joke")]
    assert not task.done()
    failures = [r.getMessage() for r in caplog.records]
    assert len(failures) == 2 and "could not set /state_resources for state joke" in failures[1]


def test_an_error_that_stops_the_controller_is_logged(
    clock: VirtualClock, caplog: pytest.LogCaptureFixture
) -> None:
    transport = EmbeddedTransport(clock)
    Modules(transport)
    controller = Controller(transport.node("cyborg_controller"), parse_config(MACHINE).machine)

    def publish(message: object) -> None:
        raise RuntimeError("publisher broken")

    controller._state_pub.publish = publish  # type: ignore[method-assign]
    task = controller.start()
    with caplog.at_level(logging.CRITICAL, logger="cyborg.controller.runtime"):
        clock.run(clock.sleep(0.5))
    assert task.done()
    [record] = caplog.records
    assert "the controller stopped in state idle" in record.getMessage()
    assert "publisher broken" in record.getMessage()
