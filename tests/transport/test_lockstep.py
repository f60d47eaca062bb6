"""Lockstep time without ROS: a time server and nodes on LockstepClocks, each on a thread of its own.

The server grants the earliest next timer of all nodes once every node is idle and every message
counted out has been counted in; a node's clock reads exactly the granted times.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from cyborg.run.lockstep import TimeServer
from cyborg.transport.ledger import Channel, Ledger
from cyborg.transport.lockstep import LockstepClock

UNTIL = 1.5


@pytest.fixture
def server() -> Iterator[TimeServer]:
    time_server = TimeServer({"a", "b"}, patience=30.0).start()
    yield time_server
    time_server.close()


def run_node(clock: LockstepClock, name: str, main: Callable[[], object]) -> threading.Thread:
    def run() -> None:
        clock.join(name)
        clock.run(main())  # type: ignore[arg-type]
        clock.close()

    thread = threading.Thread(target=run, name=name, daemon=True)
    thread.start()
    return thread


def send_late(a: LockstepClock, b: LockstepClock, order: list[str], *, say_delivered: bool = False) -> None:
    """A counts a message out on /chat; it reaches B 0.3 real seconds later."""

    def deliver_late() -> None:
        time.sleep(0.3)
        if say_delivered:
            order.append("delivered")
        b.deliver("/chat", "a", order.append, "taken by b", counted=("/chat",))

    a.ledger.sent("/chat")
    threading.Thread(target=deliver_late, daemon=True).start()


def test_every_node_reads_the_times_its_timers_are_due(server: TimeServer) -> None:
    fired: dict[str, list[float]] = {"a": [], "b": []}
    clocks = {name: LockstepClock(server.address) for name in fired}

    def ticker(name: str, period: float) -> Callable[[], object]:
        async def main() -> None:
            while clocks[name].monotonic() < UNTIL:
                await asyncio.sleep(period)
                fired[name].append(clocks[name].monotonic())

        return main

    threads = [run_node(clocks["a"], "a", ticker("a", 0.3)), run_node(clocks["b"], "b", ticker("b", 0.5))]
    for thread in threads:
        thread.join(timeout=30)
    assert fired["a"] == pytest.approx([0.3, 0.6, 0.9, 1.2, 1.5], abs=1e-9)
    assert fired["b"] == pytest.approx([0.5, 1.0, 1.5], abs=1e-9)
    assert server.time_ns == 1_500_000_000
    assert not server.written_off


def test_the_time_waits_for_a_message_on_its_way(server: TimeServer) -> None:
    """A sends on /chat at 0.1 s; B takes it 0.3 real seconds later: A's timer at 0.2 s comes after."""
    a, b = LockstepClock(server.address), LockstepClock(server.address)
    b.ledger.listen("/chat", Channel.BROADCAST)
    order: list[str] = []

    async def main_a() -> None:
        await asyncio.sleep(0.1)
        send_late(a, b, order, say_delivered=True)
        await asyncio.sleep(0.1)
        order.append(f"a at {a.monotonic():.1f}")

    async def main_b() -> None:
        while b.monotonic() < 0.3:
            await asyncio.sleep(0.05)

    threads = [run_node(a, "a", main_a), run_node(b, "b", main_b)]
    for thread in threads:
        thread.join(timeout=30)
    assert order == ["delivered", "taken by b", "a at 0.2"]
    assert not server.written_off


def test_work_that_waits_for_the_instant_to_settle_runs_after_every_message_of_it(server: TimeServer) -> None:
    """B waits for 0.1 s to settle; A's message of 0.1 s reaches B late (0.3 real s): B's settled
    work still sees it, and runs before the time moves on to A's next timer."""
    a, b = LockstepClock(server.address), LockstepClock(server.address)
    b.ledger.listen("/chat", Channel.BROADCAST)
    order: list[str] = []

    async def main_a() -> None:
        await asyncio.sleep(0.1)
        send_late(a, b, order)
        await asyncio.sleep(0.1)
        order.append(f"a at {a.monotonic():.1f}")

    async def main_b() -> None:
        await asyncio.sleep(0.1)
        b.when_settled(lambda: order.append(f"b settled at {b.monotonic():.1f}"))
        while b.monotonic() < 0.3:
            await asyncio.sleep(0.05)

    threads = [run_node(a, "a", main_a), run_node(b, "b", main_b)]
    for thread in threads:
        thread.join(timeout=30)
    assert order == ["taken by b", "b settled at 0.1", "a at 0.2"]


def test_a_node_outside_the_lockstep_is_named_and_the_time_waits_while_they_talk(
    server: TimeServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A reports the graph: a student's node outside the lockstep is named to every node. While it
    only sits there the time runs as fast as ever; once A sends a goal to a server outside the
    lockstep, no new time comes until the graph is quiet (a window of an hour here); once the
    node has left, the time moves on."""
    import cyborg.run.lockstep as server_module
    import cyborg.transport.lockstep as node_module

    monkeypatch.setattr(server_module, "FOREIGN_QUIET", 3600.0)
    monkeypatch.setattr(server_module, "FOREIGN_TALK", 3600.0)  # however slow the machine
    monkeypatch.setattr(node_module, "GRAPH_LOOK", 0.05)
    graph = ["a", "b", "rosout", "a_clock", "_cyborg_graph_1", "student_module"]
    a, b = LockstepClock(server.address), LockstepClock(server.address)
    named: list[tuple[str, ...]] = []
    b.on_foreign.append(named.append)
    reached: list[tuple[str, float]] = []
    looks: list[int] = []

    def names() -> list[str]:
        looks.append(1)
        return list(graph)

    a.watch_graph(names)
    deadline = time.monotonic() + 60  # a bound, not a pace: a loaded machine is slow
    while len(looks) < 2 and time.monotonic() < deadline:  # its first look is in before the time starts
        time.sleep(0.01)

    async def main_a() -> None:
        await asyncio.sleep(0.1)
        reached.append(("a", a.monotonic()))
        a.ledger.sent("/student_module/act#goal")  # no server in the lockstep: one outside
        await asyncio.sleep(0.1)
        reached.append(("a", a.monotonic()))

    async def main_b() -> None:
        await asyncio.sleep(0.3)
        reached.append(("b", b.monotonic()))

    threads = [run_node(a, "a", main_a), run_node(b, "b", main_b)]
    deadline = time.monotonic() + 60  # a bound, not a pace: a loaded machine is slow
    while not (server.foreign and reached) and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(0.3)
    # The nodes hear of it with their next grant (b's comes once the time moves on: below).
    assert server.foreign == ("student_module",)
    assert reached == [("a", 0.1)] and server.time_ns == 100_000_000, "the time waited for quiet"
    graph.remove("student_module")
    for thread in threads:
        thread.join(timeout=30)
    assert named == [("student_module",), ()]
    assert reached == [("a", 0.1), ("a", 0.2), ("b", 0.3)] and server.foreign_seen == {"student_module"}


def test_a_channel_the_ledger_ignores_is_no_step_of_the_run() -> None:
    """The recorder hears the ROS log, which every node publishes outside the transport's counts:
    counted, each warning would be a surplus from outside and slow the time down."""
    ledger = Ledger()
    ledger.ignore("/rosout")
    ledger.listen("/rosout")
    ledger.received("/rosout", 3)
    ledger.listen("/state_change")
    ledger.received("/state_change")
    changes = ledger.take_changes()
    assert changes is not None
    assert changes["recv"] == {"/state_change": 1} and set(changes["listen"]) == {"/state_change"}


class _RacedLoopClock(LockstepClock):
    """A node's clock whose event loop a middleware thread (a message arriving) and the thread that
    builds the node's parts (a timer) ask for at once: the first asker makes it slowly."""

    def __init__(self, address: str) -> None:
        super().__init__(address)
        self.arrival_making_loop = threading.Event()
        self.timer_set = threading.Event()

    def _make_loop(self) -> asyncio.AbstractEventLoop:
        if threading.current_thread().name == "arrival":
            self.arrival_making_loop.set()
            self.timer_set.wait(0.3)  # (never set when the loop is made once: then it waits 0.3 s)
        return super()._make_loop()


def test_a_timer_set_while_a_message_arrives_on_another_thread_is_kept() -> None:
    """Scenario D over ROS 2 once had a motivator that never decided: its periodic timer was set on
    an event loop that a message arriving on an executor thread, at the same moment, replaced with
    a loop of its own. The node's clock makes one loop, whoever asks first."""
    server = TimeServer({"a"}, patience=30.0).start()
    clock = _RacedLoopClock(server.address)
    fired: list[float] = []
    try:
        arrival = threading.Thread(
            target=clock.deliver, args=("/chat", "b", None), name="arrival", daemon=True
        )
        arrival.start()
        assert clock.arrival_making_loop.wait(10)

        def set_timer() -> None:
            clock.call_later(0.5, lambda: fired.append(clock.monotonic()))
            clock.timer_set.set()

        builder = threading.Thread(target=set_timer, name="builder", daemon=True)
        builder.start()
        arrival.join(10)
        builder.join(10)
        clock.join("a")
        clock.run(clock.sleep(1.0))
    finally:
        clock.close()
        server.close()
    assert fired == pytest.approx([0.5], abs=1e-9)
