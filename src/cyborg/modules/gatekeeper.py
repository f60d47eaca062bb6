"""Gatekeeper: a relay in front of an output module (thesis 3.3 and 6.1.1).

It relays messages from an input topic to an output topic only when their
sender is the node the active state grants the gatekeeper's resource. On every
state change it reads the active state's resource list from the parameter
``/state_resources``. Until it has read a list it passes nothing (fail closed).
If the parameter cannot be read (over ROS: the master does not answer), it passes
nothing and reads it again every READ_RETRY seconds until it finds a resource
list (a restarted master gets the list from the controller when it is back).

The controller sets the parameter before it publishes the state change and sends the new
state's goal, but the module's first message may still arrive before the state change does
(they come from different nodes: nothing orders them; seen over ROS 2). So the first message a
sender would have dropped in a state makes the gatekeeper read the parameter again (once per
sender and state, so a flood costs no more reads), and it passes when the parameter already
grants that sender the resource.

Each message passed or dropped is also told, as JSON (gatekeeper, resource, holder, sender,
message), on ``GATEKEEPER_PASSED`` or ``GATEKEEPER_DROPPED``: the flight recorder keeps both.
"""

from __future__ import annotations

import asyncio
import json
import logging
from collections import Counter
from dataclasses import dataclass, field

from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node, normalize_node_name
from cyborg.transport.messages import Message, String, SystemState

log = logging.getLogger(__name__)

READ_RETRY = 0.5  # seconds between reads of the resources while they cannot be read


@dataclass
class GatekeeperStats:
    passed: int = 0
    dropped: int = 0
    dropped_by_sender: Counter[str] = field(default_factory=Counter)


class Gatekeeper:
    """Relays ``input_topic`` -> ``output_topic`` for the node holding ``resource``."""

    def __init__(
        self,
        node: Node,
        *,
        input_topic: str,
        output_topic: str,
        resource: str,
        msg_type: type[Message] = String,
    ) -> None:
        self.node = node
        self.resource = resource
        self.input_topic = input_topic
        self.output_topic = output_topic
        self.allowed: str | None = None
        self.known = False
        self.stats = GatekeeperStats()
        self._warned: set[str] = set()  # senders already logged at INFO in this state
        self._read_for: set[str] = set()  # senders whose message made it read the resources again
        self._retry: asyncio.TimerHandle | None = None  # the next read while reading fails
        self._output = node.publisher(output_topic, msg_type)
        self._drops = node.publisher(topics.GATEKEEPER_DROPPED, String, queue_size=100)
        self._passes = node.publisher(topics.GATEKEEPER_PASSED, String, queue_size=100)
        node.subscribe(topics.STATE_CHANGE, SystemState, self._on_state_change)
        node.subscribe(input_topic, msg_type, self._on_message, queue_size=100)

    def close(self) -> None:
        """Stop retrying to read the resources (the node's shutdown stops the relay)."""
        if self._retry is not None:
            self._retry.cancel()
            self._retry = None

    def _on_state_change(self, message: SystemState, info: MessageInfo) -> None:
        self._read_for.clear()
        if self._retry is not None:
            self._retry.cancel()
            self._retry = None
        self._read_resources()

    def _read_resources(self) -> None:
        retrying, self._retry = self._retry is not None, None
        try:
            resources = self.node.get_param(topics.STATE_RESOURCES_PARAM)
        except Exception as exc:
            if not retrying:
                log.warning(
                    "%s: could not read %s (%s); passing nothing and reading it again every %.1f s",
                    self.node.name,
                    topics.STATE_RESOURCES_PARAM,
                    exc,
                    READ_RETRY,
                )
            self._fail_closed_and_retry()
            return
        if retrying and not isinstance(resources, dict):
            self._fail_closed_and_retry()  # a restarted master may not hold them yet
            return
        if not isinstance(resources, dict):
            log.warning(
                "%s: %s is not a resource list (%r); passing nothing",
                self.node.name,
                topics.STATE_RESOURCES_PARAM,
                resources,
            )
            self.allowed, self.known = None, False
            return
        holder = resources.get(self.resource)
        self.allowed = normalize_node_name(holder) if isinstance(holder, str) else None
        self.known = True
        self._warned.clear()
        if retrying:
            log.info(
                "%s: read %s again: %s is held by %s",
                self.node.name,
                topics.STATE_RESOURCES_PARAM,
                self.resource,
                self.allowed or "nobody",
            )

    def _fail_closed_and_retry(self) -> None:
        self.allowed, self.known = None, False
        self._retry = self.node.clock.call_later(READ_RETRY, self._read_resources)

    def _grants(self, sender: str) -> bool:
        return self.known and self.allowed is not None and normalize_node_name(sender) == self.allowed

    def _on_message(self, message: Message, info: MessageInfo) -> None:
        if not self._grants(info.sender) and info.sender not in self._read_for and self._retry is None:
            self._read_for.add(info.sender)
            self._read_resources()  # its state change may not have reached us yet (module docstring)
        what = message.data if isinstance(message, String) else type(message).__name__
        verdict = {"gatekeeper": self.node.name, "resource": self.resource, "holder": self.allowed}
        if self._grants(info.sender):
            self.stats.passed += 1
            self._output.publish(message)
            self._passes.publish(String(json.dumps({**verdict, "sender": info.sender, "message": what})))
            return
        self.stats.dropped += 1
        self.stats.dropped_by_sender[info.sender] += 1
        self._drops.publish(String(json.dumps({**verdict, "sender": info.sender, "message": what})))
        first_in_state = info.sender not in self._warned
        self._warned.add(info.sender)
        log.log(
            logging.INFO if first_in_state else logging.DEBUG,
            "%s: dropped a message from %s (%s is held by %s; %d dropped so far)",
            self.node.name,
            info.sender,
            self.resource,
            self.allowed or "nobody",
            self.stats.dropped,
        )

    def report(self) -> dict[str, object]:
        """The counts, for status displays: resource, holder, passed, dropped and by whom."""
        return {
            "resource": self.resource,
            "held_by": self.allowed,
            "passed": self.stats.passed,
            "dropped": self.stats.dropped,
            "dropped_by_sender": dict(self.stats.dropped_by_sender),
        }
