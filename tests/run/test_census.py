"""Who else is on the graph (cyborg.run.census): the domain a robot must pick, names in use."""

from __future__ import annotations

import pytest

from cyborg.run import census
from cyborg.run.census import graph_name, ros2_domain_problem, wait_for_graph


@pytest.mark.parametrize(
    ("domain", "reach", "refused"),
    [
        (None, None, True),  # domain 0 of the whole subnet: what two robots merged on
        (None, "SUBNET", True),
        (None, "LOCALHOST", False),
        ("42", None, False),
        ("42", "SUBNET", False),
    ],
)
def test_a_ros2_robot_must_be_put_on_a_domain_deliberately(
    monkeypatch: pytest.MonkeyPatch, domain: str | None, reach: str | None, refused: bool
) -> None:
    for name, value in (("ROS_DOMAIN_ID", domain), ("ROS_AUTOMATIC_DISCOVERY_RANGE", reach)):
        if value is None:
            monkeypatch.delenv(name, raising=False)
        else:
            monkeypatch.setenv(name, value)
    problem = ros2_domain_problem()
    assert (problem is not None) == refused
    if problem is not None:
        assert "export ROS_DOMAIN_ID=42" in problem and "ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST" in problem


def test_the_graph_is_named_for_people(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ROS_DOMAIN_ID", "42")
    monkeypatch.delenv("ROS_AUTOMATIC_DISCOVERY_RANGE", raising=False)
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    assert graph_name("ROS 2") == "ROS 2 domain 42 (discovery: the local network)"
    monkeypatch.setenv("ROS_MASTER_URI", "http://robot:11311")
    assert graph_name("ROS 1") == "ROS 1 master http://robot:11311"


def test_a_name_seen_during_discovery_is_taken_unless_it_vanishes_as_a_killed_process_does(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(census, "DISCOVERY_SETTLE", 0.1)
    monkeypatch.setattr(census, "GHOST_WAIT", 0.3)
    looks = 0

    def ghost_then_gone() -> set[str]:
        nonlocal looks
        looks += 1
        return {"cyborg_music", "other"} if looks < 4 else {"other"}

    assert wait_for_graph(ghost_then_gone, {"cyborg_music"}, settle=0.1) == set()
    assert wait_for_graph(lambda: {"cyborg_music"}, {"cyborg_music", "cyborg_api"}, settle=0.1) == {
        "cyborg_music"
    }
    assert wait_for_graph(lambda: {"other"}, {"cyborg_music"}, settle=0.1) == set()


class _FakeTime:
    """A clock that moves only when the census sleeps."""

    def __init__(self) -> None:
        self.now = 0.0

    def sleep(self, seconds: float) -> None:
        self.now += seconds


def test_the_look_at_the_graph_ends_soon_once_discovery_shows_another_process() -> None:
    time = _FakeTime()

    def graph() -> set[
        str
    ]:  # this process's probe at once; a sibling at 0.2 s; the other robot's music at 0.4 s
        return (
            {"_probe"}
            | ({"cyborg_api"} if time.now >= 0.2 else set())
            | ({"cyborg_music"} if time.now >= 0.4 else set())
        )

    taken = wait_for_graph(
        graph, {"cyborg_music"}, settle=1.5, own={"_probe"}, clock=lambda: time.now, sleep=time.sleep
    )
    assert taken == {"cyborg_music"}  # seen within the look after the first other node
    assert time.now < 1.5 + census.GHOST_WAIT  # it did not wait the whole settle first

    time.now = 0.0
    assert (
        wait_for_graph(
            graph, {"cyborg_idle"}, settle=1.5, own={"_probe"}, clock=lambda: time.now, sleep=time.sleep
        )
        == set()
    )
    assert 0.2 + census.SETTLE_AFTER_OTHERS <= time.now < 0.2 + census.SETTLE_AFTER_OTHERS + 0.1

    time.now = 0.0  # a graph with nobody else: the whole settle, in case discovery is slow
    assert (
        wait_for_graph(
            lambda: {"_probe"},
            {"cyborg_idle"},
            settle=1.5,
            own={"_probe"},
            clock=lambda: time.now,
            sleep=time.sleep,
        )
        == set()
    )
    assert time.now >= 1.5
