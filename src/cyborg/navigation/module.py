"""The navigation module (thesis chapter 7 and 9.2) as a behaviour module.

It listens to speech-to-text for commands and questions, keeps a calendar
scheduler, and serves three states: planning (where to go, from the event and
the emotion), moving (drives the base through the ROSARNL interface, or on ROS 2
nav2's: :mod:`.base_link`; or wanders) and talking (what to say, by event and emotion). It speaks on
``/text_to_speech`` and sends emotional feedback like any module.
"""

from __future__ import annotations

import asyncio
import logging
import math
import random
from datetime import UTC

from cyborg.errors import CyborgError
from cyborg.modules.behaviour import Abort, BehaviourModule, GoalContext
from cyborg.modules.problems import ProblemReporter
from cyborg.modules.speech import estimated_duration
from cyborg.navigation.base_link import base_link
from cyborg.navigation.behaviour import (
    ANGRY,
    RESPONSE_FOR_TALK,
    Origin,
    Plan,
    PlanKind,
    TalkKind,
    Trip,
    origin_of,
    plan,
    sentence,
    should_stop_wandering,
    talk_kind,
)
from cyborg.navigation.calendar import CalendarEntry
from cyborg.navigation.database import NavigationDatabase
from cyborg.navigation.dialogue import Answer, Reply, ReplyKind, Request, after_answer, reply_to
from cyborg.navigation.events import ongoing_among
from cyborg.navigation.keywords import Intent, detect_answer, detect_navigation
from cyborg.navigation.models import CalendarEvent, Location, Occurrence, ResponseType
from cyborg.navigation.watchdog import TripWatch
from cyborg.transport import topics
from cyborg.transport.base import GoalStatus, MessageInfo, Node
from cyborg.transport.messages import PoseWithCovarianceStamped, SystemState
from cyborg.transport.topics import BaseApi

log = logging.getLogger(__name__)

PLANNING_ACTION = "cyborg_navigation/planning"
MOVING_ACTION = "cyborg_navigation/moving"
TALKING_ACTION = "cyborg_navigation/talking"

MOVING_FEEDBACK = (0.0, 0.015, 0.01)
WANDERING_FEEDBACK = (0.02, 0.05, 0.02)
ARRIVAL_PLEASURE_SCALE = 0.125  # pleasantness 0.8 -> +0.1 pleasure on arrival
AT_PLACE_DISTANCE = 3.0
WANDER_CHECK = 1.0
"""Seconds between checks of the emotion while wandering."""
WANDER_DEBOUNCE = 2.0
"""Seconds the emotion must stay outside bored/unconcerned/curious before wandering ends (one
flicker of the label between two emotions does not end it)."""
SPOKEN_TO_GRACE = 3.0
"""A wander that starts this many seconds after someone spoke to the robot ends at once."""
REQUEST_PATIENCE = 5.0
"""Seconds a request's event is offered again at state changes if the controller dropped it."""
OWN_STATES = frozenset({"navigation_planning", "navigation_moving", "navigation_talking"})


class NavigationModule(BehaviourModule):
    """Planning, moving and talking states plus speech and calendar event detection."""

    def __init__(
        self,
        node: Node,
        db: NavigationDatabase,
        *,
        rng: random.Random,
        scheduler_interval: float = 10.0,
        scheduler_repeat: float = 20.0,
        answer_timeout: float = 20.0,
        feedback_interval: float = 15.0,
        wander_limit: float = 600.0,
        base_api: BaseApi = BaseApi.ROSARNL,
        base_answer_timeout: float | None = None,
        pose_timeout: float | None = None,
    ) -> None:
        super().__init__(node)
        self.db = db
        self.owns_db = False
        """True when the module opened ``db`` itself (its kind's factory did): close() closes it."""
        self.rng = rng
        self.problems = ProblemReporter(node)
        self.scheduler_interval = scheduler_interval
        self.scheduler_repeat = scheduler_repeat
        self.answer_timeout = answer_timeout
        self.feedback_interval = feedback_interval
        self.wander_limit = wander_limit
        self.base_answer_timeout = base_answer_timeout
        self.pose_timeout = pose_timeout
        self.pose: tuple[float, float] | None = None
        self.pose_at = -math.inf
        """When the last pose came (clock seconds, monotonic)."""
        self.requested: Location | None = None
        self.asked: Location | None = None
        self.scheduled: Location | None = None
        self.guiding = False
        self.origin: Origin | None = None
        self.current_plan: Plan | None = None
        self.heading_to: Location | None = None
        self.arrived_at: Location | None = None
        self.failed_target: Location | None = None
        self.trip: Trip | None = None  # the drive under way (kept when a question on the way stops it)
        self.resume: Trip | None = None  # the drive to go on with after answering that question
        self.last_scheduler_event = -math.inf
        self.system_state = ""
        self.sulking = False
        self.wandering_now = False
        self._closing = False
        self._expanding: asyncio.Future[list[Occurrence]] | None = None
        """The calendar being looked at on a worker thread (real time only)."""
        self.emotion_since = node.clock.monotonic()
        self._warned_off_map: set[str] = set()
        self.request: Request | None = None
        """What a person asked for, waiting for the talking state (set with the event that leads there)."""
        self._inbox: asyncio.Queue[Request | Answer] | None = None
        """While the talking state runs: what the person says to it (answers and new requests)."""
        self._unanswered: tuple[str, float] | None = None
        """A request's event the controller has not taken yet, and until when to offer it again."""
        self.conversing = False
        """True from entering the conversation until the robot is idle again (talking returns there)."""
        self.spoken_to_at = -math.inf
        """When someone last said something that is no navigation request (a wander ends for it)."""
        self.base = base_link(node, base_api)
        node.subscribe(topics.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=10)
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_state_change)
        self.on_speech_text(self._on_text)
        self.on_unsure_speech(self._on_unsure)
        self.on_emotion_change(self._on_emotion_change)
        self.serve(PLANNING_ACTION, self.planning)
        self.serve(MOVING_ACTION, self.moving)
        self.serve(TALKING_ACTION, self.talking)
        self._scheduler = node.clock.every(
            scheduler_interval, self._check_schedule, name="the navigation scheduler", logger=log
        )

    def close(self) -> None:
        """Stop looking at the calendar and end the goal that runs; close the database if it opened it."""
        self._closing = True
        self._scheduler.cancel()
        if self._expanding is not None:
            self._expanding.cancel()
        super().close()
        if self.owns_db:
            self.db.close()

    def add_calendar_entry(self, entry: CalendarEntry) -> None:
        """Put ``entry`` (from a scenario script) in the calendar; a naive time is taken as UTC."""
        start, end = (t if t.tzinfo else t.replace(tzinfo=UTC) for t in (entry.start, entry.end))
        self.db.add_event(
            CalendarEvent(entry.location, start, end, ignored=entry.ignore, recurrence=entry.recurrence)
        )

    # --- inputs ------------------------------------------------------------------------

    def _on_state_change(self, message: SystemState, info: MessageInfo) -> None:
        self.system_state = message.to_system_state
        if message.to_system_state == "conversation":
            self.conversing = True
        elif message.to_system_state in ("idle", "navigation_moving", "music"):
            self.conversing = False
        self._offer_again(message)
        if message.to_system_state == "idle" and not self._closing:
            # In idle (at the start, or back after a person's errand, say): the calendar speaks
            # first, before the motivator's choice, instead of at its next tick (11.3.3: it returns
            # to the place) - and not at the same instant as the motivator, where the first to be
            # taken would win.
            self.node.clock.call_later(0.0, self._check_schedule)

    def _offer_again(self, change: SystemState) -> None:
        """Publish a request's event once more if the controller dropped it and the robot moved on.

        "Where is el6?" said in idle starts a conversation (10.1) and is dropped by idle (9.1 has no
        such transition): it is offered again once the conversation state is entered, and answered there.
        """
        if self._unanswered is None:
            return
        event, deadline = self._unanswered
        if change.event == event or self.node.clock.monotonic() > deadline:
            self._unanswered = None
            return
        if change.to_system_state not in OWN_STATES:
            log.info("offering %s again in %s", event, change.to_system_state)
            self.publish_event(event)

    def _on_pose(self, message: PoseWithCovarianceStamped, info: MessageInfo) -> None:
        self.pose = (message.pose.pose.position.x, message.pose.pose.position.y)
        self.pose_at = self.node.clock.monotonic()

    def _on_emotion_change(self, emotion: str, previous: str) -> None:
        self.emotion_since = self.node.clock.monotonic()

    def _on_text(self, text: str, info: MessageInfo) -> None:
        self._heard(text, unsure=False)

    def _on_unsure(self, text: str, place: str, info: MessageInfo) -> None:
        """The ears heard a request but are unsure of its place (``/cyborg_speech/unsure``): ask first."""
        self._heard(text, unsure=True)

    def _heard(self, text: str, *, unsure: bool) -> None:
        # Places on the loaded map first: on Glassgården "waiting area" is the map's "waitingarea".
        # Then the others, so that asking for one gets "not on this map" rather than silence.
        found = (
            detect_navigation(text, self.db.matcher(on_map=True))
            or detect_navigation(text, self.db.matcher())
            or (None if unsure else detect_answer(text))
        )
        if found is None or (found.intent in (Intent.YES, Intent.NO) and self._inbox is None):
            self.spoken_to_at = self.node.clock.monotonic()  # not for us: a wander stops to listen
            return
        if found.intent in (Intent.YES, Intent.NO):
            if self._inbox is not None:
                self._inbox.put_nowait(Answer.YES if found.intent is Intent.YES else Answer.NO)
            return
        location = self.db.find_location(found.location) if found.location else None
        if location is None:
            return
        log.info("heard %s about %s in %r%s", found.intent.value, location.name, text, " (unsure)" * unsure)
        # A place heard only roughly ("where is the a16") or that the ears doubt: never guess, ask
        # "Did you mean the el6?" first (a command's own question, "Shall I go to the el6?", names it).
        doubt = (unsure or not found.certain) and found.intent is not Intent.NAVIGATION_COMMAND
        self.ask(Request(found.intent, location, ResponseType.DID_YOU_MEAN if doubt else None))

    def ask(self, request: Request) -> None:
        """Hand ``request`` to the talking state: the one running, or the next (by the request's event).

        A request with a ``question`` is asked first and carried out only on yes.
        """
        if self._inbox is not None:
            self._inbox.put_nowait(request)  # the talking state runs: it takes it from there
            return
        if request.intent is Intent.NAVIGATION_COMMAND:
            self.resume = None  # a new errand
        self.request = request
        self.asked = request.place
        self._unanswered = (request.intent.value, self.node.clock.monotonic() + REQUEST_PATIENCE)
        self.publish_event(request.intent.value)

    def here(self) -> Location | None:
        """The known place on the loaded map the robot is at, if any."""
        for place in self.db.locations_on_map():
            if self._is_at(place):
                return place
        return None

    def _is_at(self, place: Location) -> bool:
        """True if the robot is at ``place`` (False if either pose is unknown)."""
        if self.pose is None or place.position is None:
            return False
        return math.dist(self.pose, place.position) <= max(place.tolerance, AT_PLACE_DISTANCE)

    def _check_schedule(self) -> None:
        """Look at the calendar. In real time its rules are expanded on a worker thread, so a costly
        one (each is bounded: cyborg.navigation.recurrence) never stops the robot's loop; in virtual
        time on the loop, so a run is the same every time."""
        now = self.node.clock.datetime()
        if self.node.clock.is_virtual:
            self._act_on_schedule(self.db.ongoing_events(now))
            return
        if self._expanding is not None:
            return  # the last look is still under way: this tick is its
        events = self.db.list_events(include_ignored=False)
        self._expanding = asyncio.ensure_future(asyncio.to_thread(ongoing_among, events, now))
        self._expanding.add_done_callback(self._expanded)

    def _expanded(self, task: asyncio.Future[list[Occurrence]]) -> None:
        self._expanding = None
        if task.cancelled() or self._closing:
            return
        error = task.exception()
        if error is not None:
            log.warning("calendar: could not look at it: %s", error)
            return
        self._act_on_schedule(task.result())

    def _act_on_schedule(self, ongoing: list[Occurrence]) -> None:
        if not ongoing:
            self.scheduled = None
            return
        place = self.db.find_location(ongoing[0].event.location)
        if place is None:
            return
        if not self.db.is_target(place):
            self.scheduled = None
            if place.name not in self._warned_off_map:
                self._warned_off_map.add(place.name)
                reason = self.db.off_map_reason if place.position else self.db.no_pose_reason
                log.warning("calendar: not going there: %s", reason(place))
            return
        self.scheduled = place
        if self.sulking and self.emotion == ANGRY:
            return  # it already walked off to be alone; asking again would only make it pace
        self.sulking = False
        at_place = self._is_at(place)
        heading_there = self.heading_to is not None and self.heading_to.name == place.name
        busy = self.system_state in OWN_STATES and not self.wandering_now  # never interrupt a user's errand
        now = self.node.clock.monotonic()
        if at_place or heading_there or busy or now - self.last_scheduler_event < self.scheduler_repeat:
            return
        self.last_scheduler_event = now
        log.info("calendar: the robot should be at %s now", place.name)
        self.publish_event("navigation_scheduler")

    # --- planning ----------------------------------------------------------------------

    async def planning(self, ctx: GoalContext) -> None:
        resume, self.resume, self.trip = self.resume, None, None
        if resume is not None and ctx.event == "navigation_command":
            await self._go_on(ctx, resume)
            return
        origin = origin_of(ctx.event, self.guiding)
        on_map = self.db.locations_on_map()
        known = self.db.list_locations()
        chosen = plan(
            origin,
            self.emotion,
            requested=self.requested,
            scheduled=self.scheduled,
            places=on_map,
            rng=self.rng,
            here=self.here(),
            off_map={p.name for p in known} - {p.name for p in on_map},
            no_pose={p.name for p in known if p.position is None},
        )
        log.info("planning (%s, %s): %s", ctx.event, self.emotion, chosen.reason)
        self.origin, self.current_plan = origin, chosen
        self.sulking = origin is Origin.SCHEDULE and self.emotion == ANGRY
        if any(chosen.feedback):
            self.send_emotion(*chosen.feedback)
        if chosen.kind is PlanKind.NOT_ON_MAP:
            assert chosen.target is not None
            log.warning("not going there: %s", self.db.off_map_reason(chosen.target))
            await ctx.sleep(self._say(ResponseType.NOT_ON_MAP, chosen.target.name))
            return
        if chosen.kind is PlanKind.NO_POSE:
            assert chosen.target is not None
            log.warning("not going there: %s", self.db.no_pose_reason(chosen.target))
            await ctx.sleep(self._say(ResponseType.NO_POSE, chosen.target.name))
            return
        if chosen.kind is PlanKind.STAY:
            return  # succeeded: back to idle, where it is
        if chosen.kind is PlanKind.NOTHING:
            raise Abort(chosen.reason)
        self.publish_event(
            "navigation_start_moving" if chosen.kind is PlanKind.MOVE else "navigation_start_wandering"
        )
        await ctx.wait_forever()

    async def _go_on(self, ctx: GoalContext, trip: Trip) -> None:
        """Go on with ``trip`` after answering a question on the way: no new decision, no refusal."""
        target = self.db.find_location(trip.target.name)
        if target is None or not self.db.is_target(target):
            raise Abort(f"cannot go on to {trip.target.name}: it is no target any more")
        log.info("planning (%s): goes on to %s after answering", ctx.event, target.name)
        self.origin, self.current_plan = trip.origin, Plan(PlanKind.MOVE, f"goes on to {target.name}", target)
        await ctx.sleep(self._say(ResponseType.RESUME, target.name))
        self.publish_event("navigation_start_moving")
        await ctx.wait_forever()

    # --- moving ------------------------------------------------------------------------

    async def moving(self, ctx: GoalContext) -> None:
        chosen = self.current_plan
        if chosen is None or chosen.kind not in (PlanKind.MOVE, PlanKind.WANDER):
            raise Abort("nothing planned: the moving state needs the planning state first")
        self.current_plan = None
        if chosen.kind is PlanKind.WANDER:
            await self._wander(ctx)
            return
        assert chosen.target is not None
        await self._move_to(ctx, chosen.target)

    async def _move_to(self, ctx: GoalContext, target: Location) -> None:
        if target.position is None:
            self.failed_target = target
            raise Abort(self.db.no_pose_reason(target))
        if not await self.base.ready(2.0):
            self.failed_target = target
            missing = f"no robot base: {self.base.name} is not offered"
            self.problems.report(missing, "start the base's node (cyborg doctor names it)", key="base")
            raise Abort(missing)
        x, y = target.position
        self.heading_to = target
        self.trip = Trip(self.origin, target)
        clock = self.node.clock
        watch = TripWatch(
            self.base.name,
            topics.AMCL_POSE,
            clock.monotonic(),
            answer_timeout=self.base_answer_timeout,
            pose_timeout=self.pose_timeout,
        )
        handle = self.base.go(x, y, target.heading)
        step = watch.step(self.feedback_interval)
        last_feedback = clock.monotonic()
        try:
            while True:
                try:
                    status = await asyncio.wait_for(asyncio.shield(handle.wait()), step)
                    break
                except TimeoutError:
                    now = clock.monotonic()
                    if now - last_feedback >= self.feedback_interval - 1e-9:
                        self.send_emotion(*MOVING_FEEDBACK)
                        last_feedback = now
                    problem = watch.problem(now, handle.status is not GoalStatus.PENDING, self.pose_at)
                    if problem is not None:
                        self.failed_target, self.trip = target, None  # given up: not to go on with
                        what, _, fix = problem.partition("; fix: ")
                        self.problems.report(f"gave up the trip to {target.name}: {what}", fix, key="base")
                        raise Abort(problem) from None
        finally:
            self.heading_to = None
            if not handle.status.is_terminal:
                handle.cancel()
        self.trip = None  # over; a trip stopped halfway (the state preempted) is kept for going on
        if status is not GoalStatus.SUCCEEDED:
            self.failed_target = target
            raise Abort(f"could not reach {target.name}: {handle.text or status.name}")
        self.arrived_at = target
        self.problems.clear("base")  # the base drove the robot there: whatever was wrong is over
        self.send_emotion(target.pleasantness * ARRIVAL_PLEASURE_SCALE, 0.0, 0.0)

    async def _wander(self, ctx: GoalContext) -> None:
        """Wander until the emotion has left bored/unconcerned/curious for ``WANDER_DEBOUNCE`` s.

        It also ends when someone says something to the robot that is no navigation request (a
        greeting: the conversation module then asks for the conversation from idle); a person's
        trip does not end for that. ``wander_limit`` is a safety cap for an emotion that never changes.
        """
        clock = self.node.clock
        if self.spoken_to_at >= clock.monotonic() - SPOKEN_TO_GRACE:
            log.info("no wander: someone is talking to the robot")
            self.publish_event("navigation_wandering_completed")
            await ctx.wait_forever()
        await self.base.wander()
        started = last_feedback = clock.monotonic()
        self.wandering_now = True
        try:
            while True:
                if self.spoken_to_at >= started - SPOKEN_TO_GRACE:
                    log.info("wandering ends: someone is talking to the robot")
                    break
                await ctx.sleep(WANDER_CHECK)
                now = clock.monotonic()
                if now - last_feedback >= self.feedback_interval:
                    self.send_emotion(*WANDERING_FEEDBACK)
                    last_feedback = now
                settled = now - self.emotion_since >= WANDER_DEBOUNCE
                if should_stop_wandering(self.emotion) and settled:
                    log.info("wandering ends: the robot is %s now", self.emotion)
                    break
                if now - started >= self.wander_limit:
                    log.info("wandering ends: %.0f s (wander_limit) are over", self.wander_limit)
                    break
        finally:
            self.wandering_now = False
            await self._stop_base()
        self.publish_event("navigation_wandering_completed")
        await ctx.wait_forever()

    async def _stop_base(self) -> None:
        try:
            await self.base.stop()
        except CyborgError as exc:
            if self._closing:  # the robot stops: its base's node (or ours) may be gone already
                log.debug("could not stop the base while closing: %s", exc)
            else:
                log.warning("could not stop the base: %s", exc)

    # --- talking -----------------------------------------------------------------------

    def _say(self, kind: ResponseType, place: str) -> float:
        """Say a sentence of ``kind``; return how long it takes to speak (0 if none fits)."""
        text = sentence(self.db.responses(kind, self.emotion), place, self.rng)
        if text is None:
            return 0.0
        self.say(text)
        return estimated_duration(text)

    async def talking(self, ctx: GoalContext) -> None:
        """Say what the event calls for (7.7); a person's request may ask a yes-or-no question first.

        Entered from the moving state with a trip under way (a question asked on the way), the
        robot drives on afterwards unless the person sent it elsewhere: nobody is left halfway.
        """
        trip, self.trip = self.trip, None
        request, self.request = self.request, None
        self._inbox = asyncio.Queue()
        try:
            set_off = await self._talk(ctx, request)
        finally:
            self._inbox = None
        self.origin = None
        if set_off:
            await ctx.wait_forever()
        if trip is not None and ctx.previous_state == "navigation_moving":
            log.info("answered on the way; going on to %s", trip.target.name)
            self.resume = trip
            self.publish_event("navigation_command")  # back through planning to the same place
            await ctx.wait_forever()
        if self.conversing:
            self.publish_event("navigation_feedback_completed")
            await ctx.wait_forever()

    async def _talk(self, ctx: GoalContext, request: Request | None) -> bool:
        """Speak for the event, then handle requests as they come; True once the robot sets off."""
        if request is None or ctx.event != request.intent.value:
            await self._speak_for_event(ctx)
            request = None
        inbox = self._inbox
        assert inbox is not None
        while True:
            if request is not None and await self._handle(ctx, request):
                return True
            request = None
            while not inbox.empty() and request is None:  # said while it was speaking
                item = inbox.get_nowait()
                request = item if isinstance(item, Request) else None
            if request is None:
                return False

    async def _speak_for_event(self, ctx: GoalContext) -> None:
        """The sentence for an arrival (guided: the place's name; else an opinion) or for being stuck."""
        kind = talk_kind(ctx.event, self.origin)
        place = {
            TalkKind.ARRIVED: self.arrived_at,
            TalkKind.OPINION: self.arrived_at,
            TalkKind.STUCK: self.failed_target,
        }.get(kind)
        if kind in RESPONSE_FOR_TALK and place is not None:
            await ctx.sleep(self._say(RESPONSE_FOR_TALK[kind], place.name))

    async def _handle(self, ctx: GoalContext, request: Request) -> bool:
        """Carry out ``request`` (asking first where the reply says so); True if the robot sets off."""
        place = self.db.find_location(request.place.name) or request.place
        reply: Reply | None = reply_to(
            request,
            self.emotion,
            on_map=self.db.on_current_map(place),
            has_pose=place.position is not None,
        )
        while reply is not None:
            log.info("talking (%s, %s): %s", request.intent.value, self.emotion, reply.reason)
            if reply.kind is ReplyKind.IGNORE:
                return False
            if reply.kind is ReplyKind.ASK:
                self._drain_answers()  # listen from the question on (also while still speaking it)
            assert reply.say is not None
            if reply.say is ResponseType.NOT_ON_MAP:
                log.warning("not going there: %s", self.db.off_map_reason(place))
            if reply.say is ResponseType.NO_POSE:
                log.warning("not going there: %s", self.db.no_pose_reason(place))
            await ctx.sleep(self._say(reply.say, place.name))
            if reply.kind is ReplyKind.GO:
                self.requested, self.guiding = place, reply.origin is Origin.GUIDE
                self.publish_event("navigation_command")
                return True
            if reply.kind is ReplyKind.SAY:
                return False
            heard = await self._await_answer()
            if isinstance(heard, Request):  # a new request instead of an answer: that one now
                return await self._handle(ctx, heard)
            reply = after_answer(reply, heard)
        return False

    def _drain_answers(self) -> None:
        """Forget yes and no said before the question (requests stay queued)."""
        inbox = self._inbox
        if inbox is None:
            return
        kept = [item for item in _drain(inbox) if isinstance(item, Request)]
        for item in kept:
            inbox.put_nowait(item)

    async def _await_answer(self) -> Answer | Request:
        inbox = self._inbox
        assert inbox is not None
        try:
            return await asyncio.wait_for(inbox.get(), self.answer_timeout)
        except TimeoutError:
            return Answer.SILENCE


def _drain(queue: asyncio.Queue[Request | Answer]) -> list[Request | Answer]:
    items: list[Request | Answer] = []
    while not queue.empty():
        items.append(queue.get_nowait())
    return items
