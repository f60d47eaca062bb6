"""Shared fixtures: a virtual clock and an embedded transport on it."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport

PROJECT_ROOT = Path(__file__).resolve().parent.parent
SHARED = PROJECT_ROOT.parent / "shared"


@pytest.fixture
def clock() -> Iterator[VirtualClock]:
    c = VirtualClock()
    yield c
    c.close()


@pytest.fixture
def transport(clock: VirtualClock) -> EmbeddedTransport:
    return EmbeddedTransport(clock)
