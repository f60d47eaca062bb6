"""The navigation module on the default robot: controller, emotion system, simulated base, speech.

The robot is built from the packaged ``cyborg.yaml`` with two changes so that
the tests alone decide what happens: the motivator has no events (it never
starts anything on its own) and the idle state's boredom is switched off (the
emotion stays where a test puts it). It starts at the information desk.
Everything runs in virtual time; a trip across the campus takes a fraction of
a real second. Some tests use the real Glassgården map instead of the campus.
"""

from __future__ import annotations

import functools
import itertools
import math
import re
import typing
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from zoneinfo import ZoneInfo

import pytest
import yaml

from cyborg.app.config import LoadedConfig, packaged_config, parse_config
from cyborg.app.registry import module_kinds
from cyborg.app.robot import build_robot
from cyborg.emotion.model import NEUTRAL, TABLE_2_2
from cyborg.maps import Cell, OccupancyMap, Point, default_map_path, load_map
from cyborg.modules.kind import BuildContext, ModuleKind
from cyborg.modules.speech import estimated_duration
from cyborg.navigation.content import DEFAULT_RESPONSES
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.kind import NavigationSettings
from cyborg.navigation.models import CalendarEvent, Location, ResponseType
from cyborg.navigation.module import WANDER_CHECK, WANDER_DEBOUNCE, NavigationModule
from cyborg.sim.base import PathState, SimulatedBase, SimulatedBaseSettings
from cyborg.sim.planner import RoutePlanner
from cyborg.testing import wait_until
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import (
    EmotionalFeedback,
    EmotionalState,
    PoseWithCovarianceStamped,
    String,
    SystemState,
)
from cyborg.transport.topics import SPOKEN_TOPIC
from tests.support.paths import GLASSGARDEN

CONFIG = packaged_config("cyborg.yaml")
EMOTIONS = sorted([NEUTRAL, *TABLE_2_2])
OSLO = ZoneInfo("Europe/Oslo")
ARRIVED = 0.1  # metres
OFFER = "I think I know where that is, would you like me to show you?"
NAV = "cyborg_navigation"
CAMPUS = load_map(default_map_path())
CROWDED = {"information desk", "cafeteria", "entrance", "waiting area"}
QUIET = {"entrance 2", "el5", "el6", "elevator"}


@functools.cache
def small_config() -> LoadedConfig:
    raw = yaml.safe_load(CONFIG.read_text())
    raw["motivator"]["events"] = []  # nothing happens on the robot's own initiative
    raw["modules"]["cyborg_idle"]["boredom"] = [0.0, 0.0, 0.0]  # the emotion stays where it is put
    return parse_config(yaml.safe_dump(raw), source=str(CONFIG))


@functools.cache
def glassgarden_map() -> OccupancyMap:
    return load_map(GLASSGARDEN)


@functools.cache
def planner_for(source: str) -> RoutePlanner:
    """Built once per map for all tests: inflating the map is the only slow part of building a robot."""
    return RoutePlanner(glassgarden_map() if source == str(GLASSGARDEN) else CAMPUS, 0.35)


def simulated_base(node: Node, settings: SimulatedBaseSettings, robot: BuildContext) -> SimulatedBase:
    """The ``simulated_base`` kind of cyborg.yaml, sharing one planner per map."""
    occupancy = robot.occupancy_map()
    planner = planner_for(occupancy.source)
    assert settings.robot_radius == planner.robot_radius
    return SimulatedBase(
        node,
        occupancy,
        rng=robot.rng,
        speed=settings.speed,
        robot_radius=settings.robot_radius,
        planner=planner,
    )


@dataclass(frozen=True)
class Said:
    t: float
    text: str
    emotion: str  # the emotion the robot had when it said it


class Cyborg:
    """The default robot plus a user: hears, speaks, and records what the robot does."""

    def __init__(
        self,
        clock: VirtualClock,
        data_dir: Path,
        *,
        seed: int = 1,
        map_path: Path | None = None,
        kinds: dict[str, ModuleKind[typing.Any]] | None = None,
        config: LoadedConfig | None = None,
    ) -> None:
        self.clock = clock
        self.transport = EmbeddedTransport(clock)
        self.robot = build_robot(
            config or small_config(),
            self.transport,
            data_dir=data_dir,
            seed=seed,
            map_path=map_path or default_map_path(),  # the example campus unless a test says otherwise
            kinds=module_kinds(
                {"simulated_base": ModuleKind(SimulatedBaseSettings, simulated_base), **(kinds or {})}
            ),
        )
        self.map: OccupancyMap = self.robot.occupancy_map()
        nav = self.robot.components[NAV]
        base = self.robot.components["rosarnl_node"]
        assert isinstance(nav, NavigationModule) and isinstance(base, SimulatedBase)
        self.nav, self.base = nav, base
        self.emotion = NEUTRAL
        self.states: list[tuple[float, str, str, str]] = []  # (t, from, event, to)
        self.said: list[Said] = []
        self.events: list[tuple[float, str]] = []  # events the navigation module sent
        self.feedback: list[tuple[float, tuple[float, float, float]]] = []  # ... and its emotional feedback
        self.poses: list[tuple[float, float, float]] = []
        node = self.transport.node("test_user")
        self._stt = node.publisher(topics.TEXT_FROM_SPEECH, String)
        self._register = node.publisher(topics.REGISTER_EVENT, String)
        self._set_emotion = node.publisher(topics.SET_EMOTIONAL_STATE, String)
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_state, queue_size=1000)
        node.subscribe(topics.EMOTIONAL_STATE, EmotionalState, self._on_emotion, queue_size=1000)
        node.subscribe(SPOKEN_TOPIC, String, self._on_spoken, queue_size=1000)
        node.subscribe(topics.REGISTER_EVENT, String, self._on_event, queue_size=1000)
        node.subscribe(topics.EMOTIONAL_FEEDBACK, EmotionalFeedback, self._on_feedback, queue_size=1000)
        node.subscribe(topics.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=10_000)
        self.robot.start()

    # --- records ----------------------------------------------------------------------------

    def _on_state(self, m: SystemState, info: MessageInfo) -> None:
        self.states.append((self.clock.monotonic(), m.from_system_state, m.event, m.to_system_state))

    def _on_emotion(self, m: EmotionalState, info: MessageInfo) -> None:
        self.emotion = m.to_emotional_state

    def _on_spoken(self, m: String, info: MessageInfo) -> None:
        self.said.append(Said(self.clock.monotonic(), m.data, self.emotion))

    def _on_event(self, m: String, info: MessageInfo) -> None:
        if info.sender == NAV:
            self.events.append((self.clock.monotonic(), m.data))

    def _on_feedback(self, m: EmotionalFeedback, info: MessageInfo) -> None:
        if info.sender == NAV:
            delta = (m.delta_pleasure, m.delta_arousal, m.delta_dominance)
            self.feedback.append((self.clock.monotonic(), delta))

    def _on_pose(self, m: PoseWithCovarianceStamped, info: MessageInfo) -> None:
        position = m.pose.pose.position
        self.poses.append((self.clock.monotonic(), position.x, position.y))

    # --- the user ---------------------------------------------------------------------------

    def hear(self, text: str) -> None:
        self._stt.publish(String(text))

    def send_event(self, event: str) -> None:
        self._register.publish(String(event))

    def set_emotion(self, name: str) -> None:
        """Through the emotion system's topic, as an operator would."""
        self._set_emotion.publish(String(name))

    # --- questions --------------------------------------------------------------------------

    @property
    def state(self) -> str | None:
        return self.robot.controller.active_state

    @property
    def position(self) -> Point:
        return (self.base.x, self.base.y)

    def at(self, place: str) -> bool:
        """At the named pose ``place`` of the robot's map."""
        return math.dist(self.position, self.map.pose(place).position) < ARRIVED

    @property
    def at_rest(self) -> bool:
        """Idle, or in the conversation that a question asked in idle starts (10.1)."""
        return self.state in ("idle", "conversation")

    def sentences(self, since: float = 0.0) -> list[str]:
        return [s.text for s in self.said if s.t >= since]

    def sent(self, event: str, since: float = 0.0, until: float = math.inf) -> list[float]:
        return [t for t, e in self.events if e == event and since <= t <= until]

    def transitions(self, since: float = 0.0) -> list[tuple[str, str, str]]:
        return [(a, e, b) for t, a, e, b in self.states if t >= since]

    def moved_since(self, t: float) -> float:
        """How far the robot drove after time ``t`` (m)."""
        assert self.poses, "no pose from the base at all (it latches one at start-up)"
        points = [(x, y) for when, x, y in self.poses if when >= t]
        return sum(math.dist(a, b) for a, b in itertools.pairwise(points))

    async def until(self, condition: Callable[[], bool], timeout: float, what: str) -> None:
        if not await wait_until(condition, self.clock, timeout=timeout, interval=0.1):
            raise AssertionError(
                f"waited {timeout} s for {what}; states {self.transitions()}, said {self.sentences()}"
            )

    async def order(self, text: str) -> None:
        """Tell the robot to go somewhere (``text``) and say yes when it asks to confirm (7.7)."""
        since = self.clock.monotonic()
        self.hear(text)
        await self.until(lambda: any(is_ask_go(t) for t in self.sentences(since)), 5.0, "its question")
        self.hear("yes")

    async def settle(self, emotion: str = NEUTRAL) -> None:
        """Let the robot start (idle), then set the emotion and wait until it is in effect."""
        await self.until(lambda: self.state == "idle", 5.0, "idle")
        self.set_emotion(emotion)
        await self.until(lambda: self.emotion == emotion and self.nav.emotion == emotion, 2.0, emotion)

    async def trip_done(self, timeout: float = 300.0) -> None:
        """Wait for the next navigation plan, then until the robot is back in idle."""
        since = self.clock.monotonic()

        def planned() -> bool:
            return any(b == "navigation_planning" for _, _, b in self.transitions(since))

        await self.until(planned, 15.0, "a plan")
        await self.until(lambda: self.state == "idle", timeout, "the trip to end")


@pytest.fixture
def cyborg(clock: VirtualClock, tmp_path: Path) -> Iterator[Cyborg]:
    robot = Cyborg(clock, tmp_path)
    yield robot
    robot.transport.shutdown()


def responses(kind: ResponseType, emotion: str, place: str) -> set[str]:
    """What the default database lets the robot say: sentences for the emotion, else for any."""
    of_kind = [r for r in DEFAULT_RESPONSES if r.type is kind]
    fitting = [r for r in of_kind if r.emotion == emotion] or [r for r in of_kind if r.emotion is None]
    return {r.say(place) for r in fitting}


def is_ask_go(text: str) -> bool:
    """True if ``text`` is the robot asking whether to go somewhere (any ask_go sentence, any place)."""
    asks = [r for r in DEFAULT_RESPONSES if r.type is ResponseType.ASK_GO]
    return any(re.fullmatch(re.escape(r.sentence).replace("LOCATION", ".+"), text) for r in asks)


def opinions(emotion: str, place: str) -> set[str]:
    return responses(ResponseType.OPINION, emotion, place)


def wall_near(point: Point) -> Point:
    rows, cols = (CAMPUS.grid == Cell.OCCUPIED).nonzero()
    centres = [CAMPUS.cell_to_world(int(r), int(c)) for r, c in zip(rows, cols, strict=True)]
    return min(centres, key=lambda centre: math.dist(centre, point))


# --- "go to X" ----------------------------------------------------------------------------------

DRIFTING = {"bored", "dignified", "loved"}
"""Emotions the two-minute trip itself changes: moving raises arousal, being bossed around
lowers dominance, and the cubic decay of every feedback takes loved's pleasure (0.89) to
curious's before the arrival's reward. The opinion then fits the emotion the robot has when it arrives."""


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_go_to_the_cafeteria_asks_to_confirm_then_drives_there_and_gives_an_opinion(
    clock: VirtualClock, cyborg: Cyborg, emotion: str
) -> None:
    """7.7: a command leads to the talking state, which asks for confirmation, or, angry, ignores it."""

    async def main() -> None:
        await cyborg.settle(emotion)
        cyborg.hear("go to the cafeteria")
        if emotion == "angry":
            await cyborg.until(lambda: cyborg.state == "idle" and len(cyborg.states) > 2, 10.0, "idle")
            cyborg.hear("yes")  # nobody asked: nothing happens
            await clock.sleep(30.0)
            return
        await cyborg.until(lambda: bool(cyborg.said), 5.0, "its question")
        assert cyborg.state == "navigation_talking" and cyborg.moved_since(0.0) == 0.0  # it waits
        await clock.sleep(5.0)
        assert cyborg.state == "navigation_talking" and cyborg.moved_since(0.0) == 0.0  # ... for an answer
        cyborg.hear("yes")
        await cyborg.trip_done()
        await clock.sleep(10.0)

    clock.run(main())
    if emotion == "angry":
        assert cyborg.sentences() == []  # ignored
        assert cyborg.moved_since(0.0) == 0.0 and cyborg.base.distance_travelled == 0.0
        assert cyborg.transitions()[1:3] == [
            ("idle", "navigation_command", "navigation_talking"),
            ("navigation_talking", "succeeded", "idle"),
        ]  # (the "yes" then starts a conversation: any text does, 10.1)
        return
    assert cyborg.at("cafeteria")
    assert cyborg.transitions()[1:] == [
        ("idle", "navigation_command", "navigation_talking"),
        ("navigation_talking", "navigation_command", "navigation_planning"),
        ("navigation_planning", "navigation_start_moving", "navigation_moving"),
        ("navigation_moving", "succeeded", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]
    question, confirmation, opinion = cyborg.said
    assert question.text in responses(ResponseType.ASK_GO, question.emotion, "cafeteria")
    assert confirmation.text in responses(ResponseType.CONFIRM, confirmation.emotion, "cafeteria")
    start_moving = next(t for t, _, _, b in cyborg.states if b == "navigation_moving")
    assert confirmation.t < start_moving  # it confirms, then drives
    assert opinion.text in opinions(opinion.emotion, "cafeteria")
    assert opinion.emotion == emotion or emotion in DRIFTING
    arrival = next(t for t, _, e, b in cyborg.states if b == "navigation_talking" and e == "succeeded")
    assert opinion.t == pytest.approx(arrival, abs=0.5)  # said on arrival


@pytest.mark.parametrize(("answer", "said"), [("no", "All right, maybe another time."), ("", None)])
def test_a_command_answered_no_or_not_at_all_leaves_the_robot_where_it_is(
    clock: VirtualClock, cyborg: Cyborg, answer: str, said: str | None
) -> None:
    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("go to the cafeteria")
        await cyborg.until(lambda: bool(cyborg.said), 5.0, "its question")
        if answer:
            cyborg.hear(answer)
        await cyborg.until(lambda: cyborg.state == "idle", 30.0, "idle")  # answer_timeout is 20 s
        cyborg.hear("yes")  # too late: nobody asked
        await clock.sleep(30.0)

    clock.run(main())
    assert cyborg.sentences() == ["Shall I go to the cafeteria?", *([said] if said else [])]
    assert cyborg.moved_since(0.0) == 0.0
    assert cyborg.transitions()[1:3] == [
        ("idle", "navigation_command", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]  # (the late "yes" starts a conversation: any text in idle does, 10.1)


def test_asked_to_confirm_a_new_request_replaces_the_question(clock: VirtualClock, cyborg: Cyborg) -> None:
    """Asked "Shall I go to the cafeteria?", the person asks where el6 is instead: that question now."""

    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("go to the cafeteria")
        await cyborg.until(lambda: bool(cyborg.said), 5.0, "its question")
        cyborg.hear("where is el6")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        cyborg.hear("yes")
        await cyborg.trip_done()

    clock.run(main())
    assert cyborg.at("el6")
    assert cyborg.sentences() == ["Shall I go to the cafeteria?", OFFER, "At once.", "Human, this is el6"]


def test_a_command_while_driving_changes_the_destination(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle()
        await cyborg.order("go to the cafeteria")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 5.0, "moving")
        await clock.sleep(20.0)
        await cyborg.order("go to the elevator")
        await cyborg.trip_done()

    clock.run(main())
    assert cyborg.at("elevator")
    assert ("navigation_moving", "navigation_command", "navigation_talking") in cyborg.transitions()
    assert cyborg.sentences() == [
        "Shall I go to the cafeteria?",
        "At once.",
        "Shall I go to the elevator?",
        "At once.",
        "I am happy about elevator",
    ]


def test_a_command_while_driving_answered_no_drives_on(clock: VirtualClock, cyborg: Cyborg) -> None:
    """Sent to the cafeteria, then "go to the elevator" on the way, then "no": the cafeteria trip goes on."""

    async def main() -> None:
        await cyborg.settle()
        await cyborg.order("go to the cafeteria")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 5.0, "moving")
        await clock.sleep(20.0)
        cyborg.hear("go to the elevator")
        await cyborg.until(lambda: len(cyborg.said) == 3, 5.0, "its question")
        cyborg.hear("no")
        await cyborg.until(lambda: cyborg.state == "idle", 300.0, "the trip to end")

    clock.run(main())
    assert cyborg.at("cafeteria")
    assert cyborg.sentences() == [
        "Shall I go to the cafeteria?",
        "At once.",
        "Shall I go to the elevator?",
        "All right, maybe another time.",
        "Now, on to cafeteria.",
        "I am happy about cafeteria",
    ]


# --- "where is X?" -------------------------------------------------------------------------------


@pytest.mark.parametrize("emotion", [NEUTRAL, "elated", "curious"])
def test_where_is_el6_yes_guides_there(clock: VirtualClock, cyborg: Cyborg, emotion: str) -> None:
    async def main() -> None:
        await cyborg.settle(emotion)
        cyborg.hear("where is el6")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        assert cyborg.state == "navigation_talking" and cyborg.moved_since(0.0) == 0.0
        cyborg.hear("yes")
        await cyborg.trip_done()

    clock.run(main())
    assert cyborg.at("el6")
    assert cyborg.sentences() == [OFFER, "At once.", "Human, this is el6"]
    assert cyborg.transitions()[1:] == [
        ("idle", "conversation_interest", "conversation"),  # any text starts a conversation (10.1) ...
        ("conversation", "navigation_information", "navigation_talking"),  # ... and is answered there
        ("navigation_talking", "navigation_command", "navigation_planning"),
        ("navigation_planning", "navigation_start_moving", "navigation_moving"),
        ("navigation_moving", "succeeded", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]
    confirmed = cyborg.said[1].t
    start_moving = next(t for t, _, _, b in cyborg.states if b == "navigation_moving")
    assert start_moving >= confirmed  # it confirms, then drives


def test_where_is_el6_no_declines_and_stays(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("where is el6")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        cyborg.hear("no")
        await cyborg.until(lambda: cyborg.state == "conversation", 30.0, "the conversation")
        await clock.sleep(60.0)

    clock.run(main())
    assert cyborg.sentences() == [OFFER, "All right, maybe another time."]
    assert cyborg.moved_since(0.0) == 0.0
    assert cyborg.transitions()[1:] == [
        ("idle", "conversation_interest", "conversation"),
        ("conversation", "navigation_information", "navigation_talking"),
        ("navigation_talking", "navigation_feedback_completed", "conversation"),  # the person is still there
    ]


def test_where_is_without_an_answer_gives_up_and_stays(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("where is el6")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        await cyborg.until(lambda: cyborg.state == "conversation", 30.0, "back")  # answer_timeout is 20 s
        cyborg.hear("yes")  # too late: nobody asked
        await clock.sleep(30.0)

    clock.run(main())
    assert cyborg.sentences() == [OFFER]
    assert cyborg.moved_since(0.0) == 0.0 and cyborg.state == "conversation"


def test_a_question_on_a_guided_trip_is_answered_and_the_trip_goes_on(
    clock: VirtualClock, cyborg: Cyborg
) -> None:
    """Issue 11.7: guided towards el6 and asked about the cafeteria on the way, it talks about the
    cafeteria (7.7), says it goes on, and brings the person to el6 instead of stopping halfway."""

    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("where is el6")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        cyborg.hear("yes")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 10.0, "moving")
        await clock.sleep(10.0)
        marks["asked"] = clock.monotonic()
        halfway.append(cyborg.position)
        cyborg.hear("what do you think of the cafeteria")
        await cyborg.until(lambda: cyborg.state == "idle", 300.0, "the trip to end")

    marks: dict[str, float] = {}
    halfway: list[Point] = []
    clock.run(main())
    assert math.dist(halfway[0], cyborg.map.pose("el6").position) > 10.0  # asked far from el6
    assert cyborg.at("el6")
    assert cyborg.sentences() == [
        OFFER,
        "At once.",
        "I am happy about cafeteria",  # the question is answered ...
        "Now, on to el6.",  # ... the person hears that the trip goes on ...
        "Human, this is el6",  # ... and is brought where they wanted to go
    ]
    assert cyborg.transitions()[1:] == [
        ("idle", "conversation_interest", "conversation"),
        ("conversation", "navigation_information", "navigation_talking"),
        ("navigation_talking", "navigation_command", "navigation_planning"),
        ("navigation_planning", "navigation_start_moving", "navigation_moving"),
        ("navigation_moving", "navigation_feedback", "navigation_talking"),
        ("navigation_talking", "navigation_command", "navigation_planning"),
        ("navigation_planning", "navigation_start_moving", "navigation_moving"),
        ("navigation_moving", "succeeded", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]
    answer, going_on = cyborg.said[2:4]
    moving_again = [t for t, _, _, b in cyborg.states if b == "navigation_moving"][1]
    spoken = estimated_duration(answer.text) + estimated_duration(going_on.text)
    assert moving_again - marks["asked"] <= spoken + 1.0  # it drives on as soon as it has said both


def test_asked_on_the_way_an_angry_robot_still_finishes_the_errand(
    clock: VirtualClock, cyborg: Cyborg
) -> None:
    """Told to go to the cafeteria, angry by the time it is asked about el5: it answers angrily
    and still goes on to the cafeteria; having said yes once, it does not refuse halfway."""

    async def main() -> None:
        await cyborg.settle()
        await cyborg.order("go to the cafeteria")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 10.0, "moving")
        await clock.sleep(10.0)
        cyborg.set_emotion("angry")
        await cyborg.until(lambda: cyborg.nav.emotion == "angry", 2.0, "angry")
        cyborg.hear("what do you think of el5")
        await cyborg.until(lambda: cyborg.state == "idle", 300.0, "the trip to end")

    clock.run(main())
    assert cyborg.at("cafeteria")
    _, confirmation, answer, going_on, arrival = cyborg.said
    assert confirmation.text == "At once."
    assert answer.emotion == "angry" and answer.text in opinions("angry", "el5")
    assert going_on.text == "Now, on to cafeteria."
    assert arrival.text in opinions(arrival.emotion, "cafeteria")
    assert cyborg.transitions()[-2:] == [
        ("navigation_moving", "succeeded", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]


def test_a_new_command_while_answering_on_the_way_wins(clock: VirtualClock, cyborg: Cyborg) -> None:
    """Asked about el5 on the way to the cafeteria, then told to go to the elevator: the elevator."""

    async def main() -> None:
        await cyborg.settle()
        await cyborg.order("go to the cafeteria")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 10.0, "moving")
        await clock.sleep(10.0)
        cyborg.hear("what do you think of el5")
        await cyborg.until(lambda: cyborg.state == "navigation_talking", 5.0, "talking")
        await cyborg.order("go to the elevator")
        await cyborg.until(lambda: cyborg.state == "idle", 300.0, "the trip to end")

    clock.run(main())
    assert cyborg.at("elevator")
    assert "Now, on to cafeteria." not in cyborg.sentences()


def test_after_a_guided_tour_a_command_is_a_command_again(clock: VirtualClock, cyborg: Cyborg) -> None:
    """Guided to el6, then told to go to the entrance: an opinion on arrival, not a tour guide's line."""

    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("where is el6")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        cyborg.hear("yes")
        await cyborg.until(lambda: "Human, this is el6" in cyborg.sentences(), 300.0, "el6")
        await cyborg.until(lambda: cyborg.state == "idle", 10.0, "idle")
        cyborg.set_emotion(NEUTRAL)
        await cyborg.order("go to the elevator")
        await cyborg.trip_done()

    clock.run(main())
    assert cyborg.at("elevator")
    last = cyborg.said[-1]
    assert last.text in opinions(last.emotion, "elevator")


# --- people around a trip (issue 28: keep the person's trip; 10.1: any text starts a conversation) ---


def test_a_greeting_on_a_guided_trip_does_not_end_it(clock: VirtualClock, cyborg: Cyborg) -> None:
    """Someone says hello to the robot while it shows a person the way: the person still gets there."""

    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("where is el6")
        await cyborg.until(lambda: OFFER in cyborg.sentences(), 5.0, "the offer")
        cyborg.hear("yes")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 10.0, "moving")
        await clock.sleep(10.0)
        cyborg.hear("hello")
        await cyborg.until(lambda: cyborg.state == "idle", 300.0, "the trip to end")

    clock.run(main())
    assert cyborg.at("el6")
    assert cyborg.sentences()[-1] == "Human, this is el6"
    assert cyborg.transitions()[-3:] == [
        ("navigation_planning", "navigation_start_moving", "navigation_moving"),
        ("navigation_moving", "succeeded", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]


def test_hello_to_a_wandering_robot_stops_the_wander_and_starts_a_conversation(
    clock: VirtualClock, cyborg: Cyborg
) -> None:
    async def main() -> None:
        await cyborg.settle("bored")
        cyborg.send_event("navigation_emotional")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 5.0, "wandering")
        await clock.sleep(20.0)
        marks["hello"] = clock.monotonic()
        cyborg.hear("hello")
        await cyborg.until(lambda: cyborg.state == "conversation", 5.0, "the conversation")
        marks["talking"] = clock.monotonic()

    marks: dict[str, float] = {}
    clock.run(main())
    assert cyborg.transitions()[-2:] == [
        ("navigation_moving", "navigation_wandering_completed", "idle"),
        ("idle", "conversation_interest", "conversation"),
    ]
    assert marks["talking"] - marks["hello"] < 3.0
    assert cyborg.moved_since(marks["talking"]) < 0.5  # it stopped to listen


@pytest.mark.parametrize("text", ["nice weather today", "what do you think of the cafeteria"])
def test_any_text_in_idle_starts_a_conversation(clock: VirtualClock, cyborg: Cyborg, text: str) -> None:
    """10.1: "if text input is detected it enters a conversation state"; a question in it is answered
    from the conversation (idle has no navigation_feedback transition, 9.1), and it returns there."""

    async def main() -> None:
        await cyborg.settle()
        cyborg.hear(text)
        await cyborg.until(lambda: cyborg.state == "conversation", 5.0, "the conversation")
        await clock.sleep(10.0)

    clock.run(main())
    assert cyborg.state == "conversation"
    assert cyborg.transitions()[1] == ("idle", "conversation_interest", "conversation")


# --- "what do you think of X?" ----------------------------------------------------------------


@pytest.mark.parametrize("emotion", EMOTIONS)
def test_what_do_you_think_of_the_cafeteria(clock: VirtualClock, cyborg: Cyborg, emotion: str) -> None:
    async def main() -> None:
        await cyborg.settle(emotion)
        cyborg.hear("what do you think of the cafeteria")
        await cyborg.until(lambda: bool(cyborg.said), 5.0, "an answer")
        await cyborg.until(lambda: cyborg.state == "conversation", 10.0, "the conversation")

    clock.run(main())
    [opinion] = cyborg.said
    assert opinion.emotion == emotion
    assert opinion.text in opinions(emotion, "cafeteria")
    assert cyborg.moved_since(0.0) == 0.0
    assert cyborg.transitions()[1:] == [
        ("idle", "conversation_interest", "conversation"),
        ("conversation", "navigation_feedback", "navigation_talking"),
        ("navigation_talking", "navigation_feedback_completed", "conversation"),
    ]


def test_opinions_differ_by_emotion(clock: VirtualClock, tmp_path: Path) -> None:
    """Happy and angry robots do not say the same thing about the same place."""
    heard: dict[str, set[str]] = {}
    for emotion in ("elated", "angry"):
        for seed in range(3):
            local = VirtualClock()
            try:
                robot = Cyborg(local, tmp_path / f"{emotion}{seed}", seed=seed)

                async def ask(robot: Cyborg = robot, emotion: str = emotion) -> None:
                    await robot.settle(emotion)
                    robot.hear("what do you think of the cafeteria")
                    await robot.until(lambda: bool(robot.said), 5.0, "an answer")

                local.run(ask())
                heard.setdefault(emotion, set()).add(robot.said[0].text)
            finally:
                local.close()
    assert heard["elated"] and heard["angry"] and not heard["elated"] & heard["angry"]


# --- an unreachable place ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("emotion", "sentence"),
    [
        (NEUTRAL, "I am stuck and cannot get to the boiler room."),
        ("inhibited", "I tried, but I could not reach the boiler room."),
    ],
)
def test_an_unreachable_place_aborts_and_says_it_is_stuck(
    clock: VirtualClock, cyborg: Cyborg, emotion: str, sentence: str
) -> None:
    x, y = wall_near(CAMPUS.pose("elevator").position)
    cyborg.nav.db.add_location(Location("boiler room", map="campus", x=x, y=y))
    start = cyborg.position

    async def main() -> None:
        await cyborg.settle(emotion)
        await cyborg.order("go to the boiler room")
        await cyborg.trip_done()
        await clock.sleep(10.0)

    clock.run(main())
    assert cyborg.transitions()[1:] == [
        ("idle", "navigation_command", "navigation_talking"),
        ("navigation_talking", "navigation_command", "navigation_planning"),
        ("navigation_planning", "navigation_start_moving", "navigation_moving"),
        ("navigation_moving", "aborted", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]
    assert cyborg.sentences()[1:] == ["At once.", sentence]
    assert cyborg.position == start
    assert cyborg.base.path_state is PathState.FAILED_PLAN


# --- the motivator's navigation_emotional ---------------------------------------------------------


@pytest.mark.parametrize(
    ("emotion", "places"),
    [("elated", CROWDED), ("loved", CROWDED), ("angry", QUIET), ("inhibited", {"cafeteria"})],
)
def test_on_its_own_it_goes_where_the_emotion_says(
    clock: VirtualClock, cyborg: Cyborg, emotion: str, places: set[str]
) -> None:
    async def main() -> None:
        await cyborg.settle(emotion)
        cyborg.send_event("navigation_emotional")  # as the motivator would
        await cyborg.trip_done()

    clock.run(main())
    [there] = [name for name in CROWDED | QUIET if cyborg.at(name)]
    assert there in places and there != "information desk"  # it starts there: somewhere else
    assert ("navigation_moving", "succeeded", "navigation_talking") in cyborg.transitions()


def test_a_sad_robot_at_the_most_pleasant_place_goes_to_the_next(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle()
        await cyborg.order("go to the cafeteria")
        await cyborg.trip_done()
        await cyborg.settle("inhibited")
        cyborg.send_event("navigation_emotional")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 5.0, "moving")
        await cyborg.until(lambda: cyborg.state == "idle", 300.0, "idle")

    clock.run(main())
    assert cyborg.at("waiting area")  # the cafeteria is nicer, but it is already there


@pytest.mark.parametrize("mood", ["elated", "inhibited", "angry"])
def test_wandering_ends_once_no_longer_bored_and_the_base_stops(
    clock: VirtualClock, cyborg: Cyborg, mood: str
) -> None:
    """Issue: wandering ends once the emotion is no longer bored, unconcerned or curious."""
    marks: dict[str, float] = {}

    async def main() -> None:
        await cyborg.settle("bored")
        cyborg.send_event("navigation_emotional")
        await cyborg.until(lambda: cyborg.base.wandering, 10.0, "wandering")
        marks["wandering"] = clock.monotonic()
        await clock.sleep(60.0)
        marks["changed"] = clock.monotonic()
        cyborg.set_emotion(mood)
        await cyborg.until(lambda: cyborg.state == "idle", 20.0, "the end of wandering")
        marks["idle"] = clock.monotonic()
        await clock.sleep(30.0)

    clock.run(main())
    assert cyborg.moved_since(marks["wandering"]) > 20.0  # a minute of wandering
    assert cyborg.transitions()[1:] == [
        ("idle", "navigation_emotional", "navigation_planning"),
        ("navigation_planning", "navigation_start_wandering", "navigation_moving"),
        ("navigation_moving", "navigation_wandering_completed", "idle"),
    ]
    assert cyborg.sent("navigation_wandering_completed") == [pytest.approx(marks["idle"], abs=0.5)]
    assert marks["idle"] - marks["changed"] <= WANDER_DEBOUNCE + WANDER_CHECK + 0.5  # within seconds
    assert cyborg.moved_since(marks["idle"]) == 0.0  # the base stopped
    assert not cyborg.base.wandering and cyborg.base.path_state is PathState.STOPPED


@pytest.mark.parametrize("mood", ["curious", "unconcerned", "bored", "neutral"])
def test_wandering_goes_on_while_bored_unconcerned_or_curious(
    clock: VirtualClock, cyborg: Cyborg, mood: str
) -> None:
    async def main() -> None:
        await cyborg.settle(mood)
        cyborg.send_event("navigation_emotional")
        await cyborg.until(lambda: cyborg.base.wandering, 10.0, "wandering")
        await clock.sleep(30.0)
        cyborg.set_emotion("curious" if mood != "curious" else "bored")  # still a wandering mood
        await clock.sleep(30.0)

    clock.run(main())
    assert cyborg.state == "navigation_moving" and cyborg.base.wandering
    assert cyborg.moved_since(50.0) > 5.0
    assert cyborg.sent("navigation_wandering_completed") == []


def test_a_moment_of_another_emotion_does_not_end_wandering(clock: VirtualClock, cyborg: Cyborg) -> None:
    """The label may flicker at a border: a second of another emotion is not the end of boredom."""

    async def main() -> None:
        await cyborg.settle("bored")
        cyborg.send_event("navigation_emotional")
        await cyborg.until(lambda: cyborg.base.wandering, 10.0, "wandering")
        await clock.sleep(30.0)
        cyborg.set_emotion("puzzled")
        await clock.sleep(WANDER_DEBOUNCE / 2)
        cyborg.set_emotion("bored")
        await clock.sleep(30.0)

    clock.run(main())
    assert cyborg.state == "navigation_moving" and cyborg.base.wandering
    assert cyborg.sent("navigation_wandering_completed") == []


# --- emotional feedback -----------------------------------------------------------------------------


def test_feedback_directions_of_a_trip(clock: VirtualClock, cyborg: Cyborg) -> None:
    pads: dict[str, tuple[float, float, float]] = {}

    async def main() -> None:
        await cyborg.settle(NEUTRAL)
        await cyborg.order("go to the cafeteria")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 5.0, "moving")
        pads["bossed"] = cyborg.robot.emotion.pad.as_tuple()
        await cyborg.until(lambda: cyborg.base.distance_travelled > 60.0, 200.0, "most of the way")
        pads["driven"] = cyborg.robot.emotion.pad.as_tuple()
        await cyborg.until(lambda: cyborg.state == "navigation_talking", 60.0, "arrival")
        await clock.sleep(0.5)
        pads["arrived"] = cyborg.robot.emotion.pad.as_tuple()

    clock.run(main())
    deltas = [delta for _, delta in cyborg.feedback]
    assert deltas[0] == (0.0, 0.0, -0.2)  # bossed around: dominance down
    moving = deltas[1:-1]
    assert len(moving) >= 6 and all(a > 0 for _, a, _ in moving)  # moving: arousal up
    assert deltas[-1][0] == pytest.approx(0.8 * 0.125) and deltas[-1][1:] == (0.0, 0.0)  # pleasant arrival
    assert pads["bossed"][2] < -0.15
    assert pads["driven"][1] > pads["bossed"][1] + 0.05
    assert pads["arrived"][0] > pads["driven"][0] + 0.05


def test_an_unpleasant_arrival_lowers_pleasure(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle(NEUTRAL)
        await cyborg.order("go to the elevator")
        await cyborg.trip_done()

    clock.run(main())
    assert cyborg.at("elevator")
    assert cyborg.feedback[-1][1][0] == pytest.approx(-0.3 * 0.125)


def test_own_choice_raises_dominance(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle("inhibited")
        cyborg.send_event("navigation_emotional")
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 5.0, "moving")

    clock.run(main())
    assert cyborg.feedback[0][1] == (0.0, 0.0, 0.1)


# --- the calendar ---------------------------------------------------------------------------------


def schedule(cyborg: Cyborg, place: str, *, start: float, end: float) -> None:
    """Be at ``place`` from ``start`` to ``end`` seconds from now."""
    now = cyborg.clock.datetime()
    cyborg.nav.db.add_event(
        CalendarEvent(place, now + timedelta(seconds=start), now + timedelta(seconds=end))
    )


def test_scheduler_sends_the_robot_to_the_place_once(clock: VirtualClock, cyborg: Cyborg) -> None:
    schedule(cyborg, "cafeteria", start=-1800, end=3600)

    async def main() -> None:
        await cyborg.trip_done()
        await clock.sleep(300.0)

    clock.run(main())
    assert cyborg.at("cafeteria")
    [fired] = cyborg.sent("navigation_scheduler")  # not while heading there, nor once there
    assert fired <= cyborg.nav.scheduler_interval + 0.1
    assert cyborg.transitions()[1:5] == [
        ("idle", "navigation_scheduler", "navigation_planning"),
        ("navigation_planning", "navigation_start_moving", "navigation_moving"),
        ("navigation_moving", "succeeded", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]
    assert cyborg.sentences() == ["I am happy about cafeteria"]


def test_scheduler_waits_for_an_event_to_start(clock: VirtualClock, cyborg: Cyborg) -> None:
    schedule(cyborg, "cafeteria", start=120, end=3600)

    async def main() -> None:
        await clock.sleep(115.0)
        assert cyborg.sent("navigation_scheduler") == [] and cyborg.state == "idle"
        await cyborg.trip_done()

    clock.run(main())
    [fired] = cyborg.sent("navigation_scheduler")
    assert 119.9 <= fired <= 130.1
    assert cyborg.at("cafeteria")


def test_scheduler_repeats_at_most_every_scheduler_repeat(clock: VirtualClock, cyborg: Cyborg) -> None:
    """In a conversation the controller does not act on it: the scheduler reminds, but rate-limited."""
    schedule(cyborg, "cafeteria", start=-60, end=3600)

    async def main() -> None:
        await cyborg.until(lambda: cyborg.state == "idle", 5.0, "idle")
        cyborg.hear("hello")
        await cyborg.until(lambda: cyborg.state == "conversation", 5.0, "a conversation")
        await clock.sleep(120.0)

    clock.run(main())
    fired = cyborg.sent("navigation_scheduler")
    assert cyborg.state == "conversation" and cyborg.moved_since(0.0) == 0.0
    gaps = [b - a for a, b in itertools.pairwise(fired)]
    assert len(fired) >= 4 and min(gaps) >= cyborg.nav.scheduler_repeat - 0.01


def test_scheduler_does_not_interrupt_a_users_errand_and_returns_after(
    clock: VirtualClock, cyborg: Cyborg
) -> None:
    schedule(cyborg, "cafeteria", start=-1800, end=3600)
    marks: dict[str, float] = {}

    async def main() -> None:
        await cyborg.trip_done()  # to the cafeteria on schedule
        assert cyborg.at("cafeteria")
        marks["errand"] = clock.monotonic()
        await cyborg.order("go to el6")
        await cyborg.until(lambda: cyborg.at("el6"), 200.0, "el6")
        marks["el6"] = clock.monotonic()
        await cyborg.until(lambda: cyborg.at("cafeteria"), 300.0, "back at the cafeteria")
        await cyborg.until(lambda: cyborg.state == "idle", 20.0, "idle")

    clock.run(main())
    assert cyborg.sent("navigation_scheduler", marks["errand"], marks["el6"]) == []  # never during the errand
    [back] = cyborg.sent("navigation_scheduler", marks["el6"])
    idle_at_el6 = next(t for t, a, _, b in cyborg.states if t >= marks["el6"] and b == "idle")
    assert back - idle_at_el6 < 0.5  # at once when the errand is over, before the motivator's choice
    assert "Human, this is el6" not in cyborg.sentences()  # an errand, not a guided tour
    last = cyborg.said[-1]
    assert last.text in opinions(last.emotion, "cafeteria")


def test_scheduler_does_not_call_back_after_the_event(clock: VirtualClock, cyborg: Cyborg) -> None:
    schedule(cyborg, "cafeteria", start=-1800, end=200)

    async def main() -> None:
        await cyborg.trip_done()
        await cyborg.order("go to the entrance")
        await cyborg.trip_done()
        await clock.sleep(300.0)

    clock.run(main())
    assert cyborg.at("entrance")
    assert len(cyborg.sent("navigation_scheduler")) == 1


def test_scheduler_interrupts_wandering(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle("bored")
        cyborg.send_event("navigation_emotional")
        await cyborg.until(lambda: cyborg.base.wandering, 10.0, "wandering")
        await clock.sleep(30.0)
        schedule(cyborg, "waiting area", start=-60, end=3600)
        await cyborg.until(lambda: cyborg.at("waiting area"), 300.0, "the waiting area")
        await clock.sleep(30.0)

    clock.run(main())
    assert ("navigation_moving", "navigation_scheduler", "navigation_planning") in cyborg.transitions()
    assert not cyborg.base.wandering and cyborg.at("waiting area")


def test_angry_ignores_the_schedule_for_a_quiet_place(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle("angry")
        schedule(cyborg, "cafeteria", start=-60, end=3600)
        await cyborg.until(lambda: cyborg.state == "navigation_moving", 20.0, "moving")
        await cyborg.until(lambda: cyborg.state == "navigation_talking", 300.0, "arrival")

    clock.run(main())
    assert not cyborg.at("cafeteria")
    assert [name for name in QUIET if cyborg.at(name)]


def test_an_angry_robot_does_not_pace_between_quiet_places(clock: VirtualClock, cyborg: Cyborg) -> None:
    async def main() -> None:
        await cyborg.settle("angry")
        cyborg.robot.emotion.enabled = False  # it stays angry: feedback is ignored
        schedule(cyborg, "cafeteria", start=-60, end=3600)
        await cyborg.until(lambda: cyborg.state == "navigation_talking", 300.0, "arrival")
        await clock.sleep(600.0)

    clock.run(main())
    assert len(cyborg.sent("navigation_scheduler")) == 1, (
        "one walk-off while angry, not one every few minutes"
    )


@pytest.mark.parametrize(("local_time", "first_call"), [((15, 10), 0.0), ((14, 50), 600.0)])
def test_weekly_event_keeps_its_local_time_across_daylight_saving(
    tmp_path: Path, local_time: tuple[int, int], first_call: float
) -> None:
    """Weekly at 15:00-16:00 Oslo time from Monday 19 October 2026 (summer time, UTC+2).

    Summer time ends on 25 October, so on Monday 26 October the event runs
    15:00-16:00 local = 14:00-15:00 UTC. Starting at 15:10 the robot is called at
    once; starting at 14:50 it is not, until 15:00 (600 s later).
    """
    clock = VirtualClock(start=datetime(2026, 10, 26, *local_time, tzinfo=OSLO))
    try:
        cyborg = Cyborg(clock, tmp_path)
        cyborg.nav.db.add_event(
            CalendarEvent(
                "cafeteria",
                datetime(2026, 10, 19, 15, 0, tzinfo=OSLO),
                datetime(2026, 10, 19, 16, 0, tzinfo=OSLO),
                recurrence="FREQ=WEEKLY",
            )
        )
        clock.run(clock.sleep(first_call + 200.0))
        fired = cyborg.sent("navigation_scheduler")
        assert fired, "the scheduler never called"
        assert first_call <= fired[0] <= first_call + cyborg.nav.scheduler_interval + 0.1
        assert all(t >= fired[0] for t, _, _ in cyborg.poses[1:])  # it did not move before the call
        assert cyborg.at("cafeteria")
    finally:
        clock.close()


# --- the real Glassgården map, and places that are not on the loaded map ------------------------


@pytest.fixture
def glassgarden(clock: VirtualClock, tmp_path: Path) -> Iterator[Cyborg]:
    robot = Cyborg(clock, tmp_path, map_path=GLASSGARDEN)
    yield robot
    robot.transport.shutdown()


@pytest.mark.parametrize(
    ("spoken", "goal", "place"),
    [
        ("go to the waiting area", "waitingarea", "waiting area"),
        ("go to the elevator", "elevator1", "elevator"),
        ("go to entrance 2", "entrance2", "entrance 2"),
        ("go to the cafeteria", "cafeteria", "cafeteria"),
    ],
)
def test_on_glassgarden_a_default_place_is_the_maps_goal(
    clock: VirtualClock, glassgarden: Cyborg, spoken: str, goal: str, place: str
) -> None:
    """The map calls them waitingarea and elevator1; the user says "the waiting area" and "the elevator"."""
    assert glassgarden.at("info")  # it starts at the information desk

    async def main() -> None:
        await glassgarden.settle()
        await glassgarden.order(spoken)
        await glassgarden.trip_done()

    clock.run(main())
    assert glassgarden.at(goal)
    assert glassgarden.transitions()[1:] == [
        ("idle", "navigation_command", "navigation_talking"),
        ("navigation_talking", "navigation_command", "navigation_planning"),
        ("navigation_planning", "navigation_start_moving", "navigation_moving"),
        ("navigation_moving", "succeeded", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
    ]
    assert glassgarden.moved_since(0.0) > 5.0
    question, confirmation, opinion = glassgarden.said
    assert question.text == f"Shall I go to the {place}?" and confirmation.text == "At once."
    assert opinion.text in opinions(opinion.emotion, place)  # it names the place as the user knows it


def test_on_glassgarden_where_is_the_waiting_area_guides_there_and_names_it(
    clock: VirtualClock, glassgarden: Cyborg
) -> None:
    async def main() -> None:
        await glassgarden.settle()
        glassgarden.hear("where is the waiting area?")
        await glassgarden.until(lambda: OFFER in glassgarden.sentences(), 5.0, "the offer")
        glassgarden.hear("yes")
        await glassgarden.trip_done()

    clock.run(main())
    assert glassgarden.at("waitingarea")
    assert glassgarden.sentences() == [OFFER, "At once.", "Human, this is waiting area"]


NOT_HERE = "I know the stairs, but it is not on the map I have here."


def stairs_from_glassgarden(tmp_path: Path) -> None:
    """Run a robot on Glassgården in ``tmp_path``: its database learns the map's places (the stairs)."""
    clock = VirtualClock()
    try:
        robot = Cyborg(clock, tmp_path, map_path=GLASSGARDEN)
        clock.run(robot.settle())
        assert robot.nav.db.get_location("stairs").map == "glassgarden"
        robot.transport.shutdown()
    finally:
        clock.close()


def test_a_place_of_another_map_is_no_target_and_the_robot_says_so(
    clock: VirtualClock, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """Same data folder, first Glassgården, then the campus: the stairs exist only on Glassgården."""
    stairs_from_glassgarden(tmp_path)
    cyborg = Cyborg(clock, tmp_path)

    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("go to the stairs")
        await cyborg.until(lambda: bool(cyborg.said), 5.0, "an answer")
        await cyborg.until(lambda: cyborg.state == "idle", 10.0, "idle")
        cyborg.hear("where is the stairs?")
        await cyborg.until(lambda: len(cyborg.said) == 2, 5.0, "a second answer")
        await cyborg.until(lambda: cyborg.state == "conversation", 10.0, "the conversation")
        cyborg.hear("yes")
        await clock.sleep(30.0)

    try:
        with caplog.at_level("WARNING", logger="cyborg.navigation.module"):
            clock.run(main())
    finally:
        cyborg.transport.shutdown()
    assert cyborg.sentences() == [NOT_HERE, NOT_HERE]  # no drive, no offer to show the way
    assert cyborg.moved_since(0.0) == 0.0 and cyborg.base.distance_travelled == 0.0
    assert cyborg.transitions()[1:] == [
        ("idle", "navigation_command", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
        ("idle", "conversation_interest", "conversation"),
        ("conversation", "navigation_information", "navigation_talking"),
        ("navigation_talking", "navigation_feedback_completed", "conversation"),
    ]
    assert "'stairs' is on map 'glassgarden', not on the map in use ('campus')" in caplog.text
    assert "cyborg db import-map" in caplog.text


def test_places_of_another_map_are_never_chosen_on_its_own(clock: VirtualClock, tmp_path: Path) -> None:
    """Glassgården's quiet hallways are in the database; an angry robot on the campus does not go there."""
    stairs_from_glassgarden(tmp_path)
    cyborg = Cyborg(clock, tmp_path)
    assert {p.name for p in cyborg.nav.db.locations_on_map()} == CROWDED | QUIET

    async def main() -> None:
        for _ in range(4):
            await cyborg.settle("angry")
            cyborg.send_event("navigation_emotional")
            await cyborg.trip_done()

    try:
        clock.run(main())
    finally:
        cyborg.transport.shutdown()
    assert [name for name in QUIET if cyborg.at(name)]


def test_a_calendar_event_at_a_place_of_another_map_is_ignored(
    clock: VirtualClock, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    stairs_from_glassgarden(tmp_path)
    cyborg = Cyborg(clock, tmp_path)
    schedule(cyborg, "stairs", start=-60, end=3600)
    with caplog.at_level("WARNING", logger="cyborg.navigation.module"):
        try:
            clock.run(clock.sleep(120.0))
        finally:
            cyborg.transport.shutdown()
    assert cyborg.sent("navigation_scheduler") == [] and cyborg.moved_since(0.0) == 0.0
    assert caplog.text.count("calendar: not going there") == 1  # said once, not every 10 s


# --- places without a pose (issue 11.6) ------------------------------------------------------


def navigation_without_a_map(
    node: Node, settings: NavigationSettings, robot: BuildContext
) -> NavigationModule:
    """The navigation module on a fresh database that no map has placed: as on a ROSARNL base whose
    map was never imported, the default places are known by name only."""
    return NavigationModule(node, NavigationDatabase(robot.data_dir / "navigation.db"), rng=robot.rng)


@pytest.fixture
def unplaced(clock: VirtualClock, tmp_path: Path) -> Iterator[Cyborg]:
    robot = Cyborg(
        clock, tmp_path, kinds={"navigation": ModuleKind(NavigationSettings, navigation_without_a_map)}
    )
    yield robot
    robot.transport.shutdown()


def test_a_place_without_a_pose_is_no_target_and_the_robot_says_so(
    clock: VirtualClock, unplaced: Cyborg, caplog: pytest.LogCaptureFixture
) -> None:
    cyborg = unplaced
    assert cyborg.nav.db.current_map() is None  # no map imported: only what the database says

    async def main() -> None:
        await cyborg.settle()
        cyborg.hear("go to the cafeteria")
        await cyborg.until(lambda: bool(cyborg.said), 5.0, "an answer")
        await cyborg.until(lambda: cyborg.state == "idle", 10.0, "idle")
        cyborg.hear("where is the cafeteria?")
        await cyborg.until(lambda: len(cyborg.said) == 2, 5.0, "a second answer")
        await cyborg.until(lambda: cyborg.state == "conversation", 10.0, "the conversation")
        cyborg.hear("yes")
        await clock.sleep(30.0)

    with caplog.at_level("WARNING", logger="cyborg.navigation.module"):
        clock.run(main())
    dont_know = "I have heard of the cafeteria, but I do not know where it is."
    assert cyborg.sentences() == [dont_know, dont_know]  # no question, no offer to show the way
    assert cyborg.moved_since(0.0) == 0.0 and cyborg.base.distance_travelled == 0.0  # not to the origin
    assert responses(ResponseType.NO_POSE, NEUTRAL, "cafeteria") == {dont_know}  # the database's sentence
    assert cyborg.transitions()[1:] == [
        ("idle", "navigation_command", "navigation_talking"),
        ("navigation_talking", "succeeded", "idle"),
        ("idle", "conversation_interest", "conversation"),
        ("conversation", "navigation_information", "navigation_talking"),
        ("navigation_talking", "navigation_feedback_completed", "conversation"),
    ]
    assert "'cafeteria' has no pose" in caplog.text
    assert "cyborg db locations set-pose 'cafeteria' --x X --y Y" in caplog.text


def test_a_calendar_event_at_a_place_without_a_pose_is_ignored(
    clock: VirtualClock, unplaced: Cyborg, caplog: pytest.LogCaptureFixture
) -> None:
    schedule(unplaced, "cafeteria", start=-60, end=3600)
    with caplog.at_level("WARNING", logger="cyborg.navigation.module"):
        clock.run(clock.sleep(120.0))
    assert unplaced.sent("navigation_scheduler") == [] and unplaced.moved_since(0.0) == 0.0
    assert caplog.text.count("calendar: not going there: location 'cafeteria' has no pose") == 1


def test_on_its_own_it_never_drives_to_a_place_without_a_pose(clock: VirtualClock, unplaced: Cyborg) -> None:
    """A loved robot looks for people at a crowded place: none has a pose but the one given by hand."""
    x, y = CAMPUS.pose("entrance").position
    unplaced.nav.db.set_pose("entrance", x, y)

    async def main() -> None:
        await unplaced.settle("loved")
        unplaced.send_event("navigation_emotional")
        await unplaced.trip_done()

    clock.run(main())
    assert unplaced.at("entrance")


def test_given_a_pose_by_hand_a_place_is_a_target(clock: VirtualClock, unplaced: Cyborg) -> None:
    x, y = CAMPUS.pose("cafeteria").position
    unplaced.nav.db.set_pose("canteen", x, y)

    async def main() -> None:
        await unplaced.settle()
        await unplaced.order("go to the cafeteria")
        await unplaced.trip_done()

    clock.run(main())
    assert unplaced.at("cafeteria")
    assert unplaced.sentences()[:2] == ["Shall I go to the cafeteria?", "At once."]
