"""Shared fixtures: a virtual clock and an embedded transport on it."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport


@pytest.fixture
def clock() -> Iterator[VirtualClock]:
    c = VirtualClock()
    yield c
    c.close()


@pytest.fixture
def transport(clock: VirtualClock) -> EmbeddedTransport:
    return EmbeddedTransport(clock)
