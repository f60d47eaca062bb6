"""What ``cyborg validate`` checks about the whole robot, beyond each file's schema.

When a configuration starts its own modules (a ``modules:`` section), it can see mistakes
that no single block shows: a state whose action no module serves (the controller would
take ``aborted``; the message suggests a served action of a similar name), a resource granted
to a node that is no module (the gatekeeper would drop what the module says), a module that
speaks in a state which does not grant it the speech gatekeeper's resource, an event a module
publishes that is no transition of any state (the controller would drop it), and two modules
listening for the same phrase (they would race for one sentence). These are warnings: an
external node may serve the action or hold the resource. Each names its line in the file.
"""

from __future__ import annotations

import difflib
from collections import defaultdict
from collections.abc import Iterable

from cyborg.app.config import LoadedConfig
from cyborg.app.registry import KindRegistry
from cyborg.configfile import key_lines
from cyborg.modules.kind import KindSettings
from cyborg.transport import topics

__all__ = ["robot_warnings"]


class _Lines:
    """``line N: `` prefixes for the parts of one configuration file."""

    def __init__(self, text: str) -> None:
        self._lines = key_lines(text) if text else {}

    def at(self, *path: str) -> str:
        line = self._lines.get(path)
        return f"line {line}: " if line is not None else ""

    def state(self, name: str, part: str | None = None) -> str:
        """Where state ``name`` (at any depth) is, or its ``part`` (``resources``) if it has one."""
        for path, line in self._lines.items():
            nested = len(path) % 2 == 0 and all(key == "states" for key in path[::2])
            if nested and path[-1] == name:
                if part is not None and (*path, part) in self._lines:
                    return f"line {self._lines[(*path, part)]}: "
                return f"line {line}: "
        return ""


def _closest(name: str, choices: Iterable[str]) -> str | None:
    """The choice most like ``name`` (a typo of it), if any is close."""
    close = difflib.get_close_matches(name, sorted(choices), n=1, cutoff=0.8)
    return close[0] if close else None


def robot_warnings(config: LoadedConfig, kinds: KindRegistry) -> list[str]:
    """Warnings about the robot ``config`` describes; none when it has no ``modules:`` section.

    The modules' settings must be valid (``KindRegistry.check``); nothing is started.
    """
    modules = config.model.modules
    if not modules:
        return []
    settings: dict[str, KindSettings] = {
        name: kinds.parse(name, raw, source=config.source)[1] for name, raw in modules.items()
    }
    lines = _Lines(config.text)
    servers: dict[str, str] = {}
    for name, module_settings in settings.items():
        for action in module_settings.serves():
            servers.setdefault(action.lstrip("/"), name)
    machine = config.machine
    warnings: list[str] = []
    for leaf in machine.leaves():
        action = (leaf.action or "").lstrip("/")
        if action not in servers:
            close = _closest(action, servers)
            hint = f" (did you mean {close!r}, served by module {servers[close]!r}?)" if close else ""
            fix = (
                f"fix: correct it to {close!r}, add a module that serves it"
                if close
                else ("fix: add a module that serves it")
            )
            warnings.append(
                f"{lines.state(leaf.name, 'action')}state {leaf.name!r}: no module in this file serves its "
                f"action {leaf.action!r}{hint}, so the controller takes 'aborted' unless an external node "
                f"offers it; {fix} (e.g. {{kind: placeholder, servers: [{{action: {action}}}]}}) or start "
                "that node"
            )
    for state in machine.states.values():
        for resource, holder in state.resources.items():
            if holder not in modules:
                warnings.append(
                    f"{lines.state(state.name, 'resources')}state {state.name!r}: resource {resource!r} goes to "
                    f"{holder!r}, which is no module's node in this file, so its gatekeeper drops what the "
                    f"modules send; fix: name the module's node (one of {', '.join(sorted(modules))}) or start "
                    f"the node {holder!r}"
                )
    warnings.extend(_speech_without_grant(config, settings, lines))
    warnings.extend(_events_nobody_takes(config, settings, lines))
    listeners: defaultdict[str, list[str]] = defaultdict(list)
    for name, module_settings in settings.items():
        for phrase in dict.fromkeys(p.strip().lower() for p in module_settings.listens_for()):
            listeners[phrase].append(name)
    for phrase, names in sorted(listeners.items()):
        if len(names) > 1:
            warnings.append(
                f"{lines.at('modules', names[-1])}modules {' and '.join(repr(n) for n in names)} both listen "
                f"for {phrase!r}: both react to one sentence and race for control; fix: let one of them "
                "listen for another phrase"
            )
    return warnings


def _speech_without_grant(
    config: LoadedConfig, settings: dict[str, KindSettings], lines: _Lines
) -> list[str]:
    """A state whose module speaks there, where a speech gatekeeper grants its resource to another node."""
    speech_gates = [
        g for g in config.model.gatekeepers if g.input.lstrip("/") == topics.TEXT_TO_SPEECH.lstrip("/")
    ]
    if not speech_gates:
        return []
    speakers: dict[str, list[str]] = defaultdict(list)
    for name, module_settings in settings.items():
        for action in module_settings.speaks_in():
            speakers[action.lstrip("/")].append(name)
    warnings = []
    machine = config.machine
    for leaf in machine.leaves():
        granted = machine.resources_of(leaf.name)
        for module in speakers.get((leaf.action or "").lstrip("/"), []):
            for gate in speech_gates:
                holder = granted.get(gate.resource)
                if holder == module:
                    continue
                held = f"to {holder!r}" if holder else "to nobody"
                warnings.append(
                    f"{lines.state(leaf.name, 'resources')}state {leaf.name!r}: module {module!r} says things "
                    f"there, but the state grants {gate.resource!r} {held}, so {gate.name} drops its "
                    f"sentences; fix: add 'resources: {{{gate.resource}: {module}}}' to state {leaf.name!r}"
                )
    return warnings


def _events_nobody_takes(config: LoadedConfig, settings: dict[str, KindSettings], lines: _Lines) -> list[str]:
    """An event a module publishes that no state has as a transition: the controller drops it."""
    machine = config.machine
    events = sorted({event for state in machine.states.values() for event in state.transitions})
    warnings = []
    for name, module_settings in settings.items():
        for event in dict.fromkeys(module_settings.publishes()):
            if event in events:
                continue
            close = _closest(event, events)
            fix = (
                f"did you mean the transition {close!r}? rename it to {event!r}, or add '{event}: <state>' "
                "to the transitions"
                if close
                else f"add '{event}: <state>' to the transitions"
            )
            warnings.append(
                f"{lines.at('modules', name)}module {name!r} publishes the event {event!r}, which is no "
                f"transition of any state, so the controller drops it; fix: {fix} of the states where it "
                "should act"
            )
    return warnings
