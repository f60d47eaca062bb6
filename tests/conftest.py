"""Shared fixtures (a virtual clock and an embedded transport on it) and the folder markers."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport

# No per-example time limit (Hypothesis's default is 200 ms): speed belongs in benchmarks/, and a
# loaded machine took 713 ms for one example of a property that holds.
settings.register_profile("cyborg", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("cyborg")

TESTS = Path(__file__).resolve().parent
FOLDER_MARKERS = {"ros": pytest.mark.ros, "ros2": pytest.mark.ros2}
"""Every test in these folders needs that middleware (pyproject.toml lists the markers)."""
NESTED_ROS2_TEST = "test_in_ros2_venv.py::test_ros2_tests_pass_in_their_venv"


@pytest.hookimpl(tryfirst=True)  # before -m deselects by marker
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if TESTS in item.path.parents:
            marker = FOLDER_MARKERS.get(item.path.relative_to(TESTS).parts[0])
            if marker is not None:
                item.add_marker(marker)


def pytest_collection_finish(session: pytest.Session) -> None:
    """Start the nested ROS 2 run at once when it is selected: it runs beside the rest."""
    if any(item.nodeid.endswith(NESTED_ROS2_TEST) for item in session.items):
        from tests.ros2.test_in_ros2_venv import start_nested_lane

        start_nested_lane(session.config)


def pytest_unconfigure(config: pytest.Config) -> None:
    from tests.ros2.test_in_ros2_venv import LANE

    lane = config.stash.get(LANE, None)
    if lane is not None:
        lane.stop()


@pytest.fixture
def clock() -> Iterator[VirtualClock]:
    c = VirtualClock()
    yield c
    c.close()


@pytest.fixture
def transport(clock: VirtualClock) -> EmbeddedTransport:
    return EmbeddedTransport(clock)


@pytest.fixture(autouse=True, scope="session")
def _recordings_in_a_scratch_folder(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Every run records (MCAP) unless told not to: the tests' runs record into a scratch folder,
    never into the data folder of whoever runs the tests."""
    import os

    from cyborg.cli.recording import RECORDINGS_ENV

    before = os.environ.get(RECORDINGS_ENV)
    os.environ[RECORDINGS_ENV] = str(tmp_path_factory.mktemp("recordings"))
    yield
    if before is None:
        os.environ.pop(RECORDINGS_ENV, None)
    else:
        os.environ[RECORDINGS_ENV] = before
