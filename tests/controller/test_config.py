"""Validation of the state machine YAML.

Every error names the file, where in it the problem is, what is wrong and how to fix it; the same
with libyaml's C loader (what the robot uses) and the Python one (every test runs with both).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from pydantic import BaseModel

from cyborg.app.config import load_config, parse_config
from cyborg.configfile import reader
from cyborg.errors import ConfigError
from tests.support.paths import DOCS


@pytest.fixture(autouse=True, params=["C loader", "Python loader"])
def yaml_loader(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """Read every YAML of these tests with libyaml's C loader, then again with the Python one."""
    if request.param == "Python loader":
        monkeypatch.setattr(reader, "yaml_loader", lambda text: yaml.SafeLoader)
    else:
        assert reader.yaml_loader("initial: idle\n") is yaml.CSafeLoader


VALID = """
states:
  idle:
    action: cyborg_idle/idle
    transitions: {music_play: music, aborted: idle}
  music:
    action: cyborg_music/play
    transitions: {succeeded: idle, aborted: idle}
"""


def problems(text: str) -> str:
    with pytest.raises(ConfigError) as info:
        parse_config(text, source="machine.yaml")
    return str(info.value)


def _in_music(extra: str) -> str:
    """VALID with ``extra`` (one key per line) added to the state 'music'."""
    return VALID.replace("    action: cyborg_music/play\n", "    action: cyborg_music/play\n" + extra)


GROUPED = """
states:
  idle: {action: a/idle, transitions: {go: group, aborted: idle}}
  group:
    transitions: {aborted: idle}
    states:
      inner: {action: a/inner}
"""

# (yaml text, fragments the message must contain): where, what is wrong, the fix.
MESSAGES: dict[str, tuple[str, list[str]]] = {
    "transitions written as a list": (
        VALID.replace("{music_play: music, aborted: idle}", "[music]"),
        [
            "machine.yaml: state 'idle' > transitions: must be a mapping (key: value), not a list ['music']",
            "fix: write transitions as a mapping event: target, e.g. {succeeded: idle",
        ],
    ),
    "transition target a number": (
        VALID.replace("music_play: music", "music_play: 1"),
        [
            "state 'idle' > transitions > music_play: must be text, not the number 1",
            "fix: the target of an event is the name of a state",
        ],
    ),
    "transition target left empty": (
        VALID.replace("music_play: music", "music_play:"),
        ["state 'idle' > transitions > music_play: must be text, not an empty value", "fix: the target"],
    ),
    "event name YAML reads as a boolean": (
        VALID.replace("music_play: music", "on: music"),
        [
            "line 5: state 'idle' > transitions: YAML reads the key 'on' as the boolean true, not as a name",
            "fix: put it in quotes, e.g. 'on':",
        ],
    ),
    "same event twice in one state's transitions": (
        VALID.replace(
            "{music_play: music, aborted: idle}", "{music_play: music, aborted: idle, music_play: idle}"
        ),
        [
            "line 5: state 'idle' > transitions: duplicate key 'music_play'",
            "the event 'music_play' is listed twice in this state's transitions",
            "fix: an event leads to exactly one target: keep the entry with the target you want",
        ],
    ),
    "same event twice, block style": (
        VALID.replace(
            "    transitions: {succeeded: idle, aborted: idle}",
            "    transitions:\n      succeeded: idle\n      aborted: idle\n      succeeded: music",
        ),
        [
            "line 11: state 'music' > transitions: duplicate key 'succeeded'",
            "(first at line 9)",
            "fix: an event",
        ],
    ),
    "state defined twice": (
        VALID + "  idle:\n    action: other/idle\n    transitions: {aborted: idle}\n",
        [
            "line 9: states: duplicate key 'idle': the state 'idle' is defined twice (first at line 3)",
            "fix: give each state a unique name, or merge the two entries",
        ],
    ),
    "resource granted twice": (
        _in_music("    resources: {speaker: a, speaker: b}\n"),
        [
            "state 'music' > resources: duplicate key 'speaker': the resource 'speaker' is granted twice",
            "fix: a resource belongs to one node at a time",
        ],
    ),
    "key twice in one state": (
        _in_music("    action: other/play\n"),
        [
            "line 8: state 'music': duplicate key 'action': this state sets 'action' twice",
            "fix: write 'action:' once",
        ],
    ),
    "section twice": (
        "timeouts: {connect: 1}\ntimeouts: {preempt: 1}\n" + VALID,
        ["line 2: top level: duplicate key 'timeouts': the section 'timeouts' appears twice", "fix: merge"],
    ),
    "state written as text": (
        VALID.replace("  music:\n    action: cyborg_music/play\n", "  music: cyborg_music/play\n  x:\n"),
        [
            "state 'music': must be a mapping (key: value), not the text 'cyborg_music/play'",
            "fix: write each state as a mapping, e.g. idle: {action: cyborg_idle/idle",
        ],
    ),
    "action a number": (
        VALID.replace("action: cyborg_music/play", "action: 3"),
        ["state 'music' > action: must be text, not the number 3", "fix: name the module's action server"],
    ),
    "action blank": (
        VALID.replace("action: cyborg_music/play", "action: ' '"),
        ["state 'music' > action: action is empty; fix: name the module's action server"],
    ),
    "resources written as a list": (
        _in_music("    resources: [speaker]\n"),
        ["state 'music' > resources: must be a mapping", "fix: write resources as a mapping resource: node"],
    ),
    "substates written as a list": (
        GROUPED.replace("      inner: {action: a/inner}", "      - inner"),
        ["state 'group' > states: must be a mapping", "fix: write substates as a mapping name: state"],
    ),
    "unknown key in a state": (
        _in_music("    actoin: x\n"),
        [
            "state 'music' > actoin: unknown key 'actoin' (did you mean 'action'?)",
            "fix: remove it or correct its spelling; the keys here are: action, description",
        ],
    ),
    "unknown section": (
        "bogus: 1\n" + VALID,
        [
            "bogus: unknown key 'bogus'; fix: remove it or correct its spelling; the keys here are: initial,",
            "emotion",
        ],
    ),
    "states written as a list": (
        "states: [idle]\n",
        [
            "states: must be a mapping (key: value), not a list ['idle']",
            "fix: write states as a mapping name",
        ],
    ),
    "no states": (
        "initial: idle\n",
        [
            "states: missing 'states' (the states: name: state); fix: write states as a mapping",
            "e.g. states: {idle:",
        ],
    ),
    "empty states": ("states: {}\n", ["states: is empty; fix: define at least one state"]),
    "file is a list": (
        "- idle\n",
        ["top level: the file holds a list ['idle']", "fix: start from the example in docs/configuration.md"],
    ),
    "file is empty": ("", ["top level: the file holds nothing (it is empty)", "fix: start from the example"]),
    "bad YAML syntax": (
        "states: {idle: [",
        ["not valid YAML", 'in "machine.yaml", line 1, column', "fix: correct the syntax at the line"],
    ),
    "initial not text": (
        "initial: [idle]\n" + VALID,
        ["initial: must be text, not a list", "fix: name the state the controller starts in"],
    ),
    "initial state unknown": (
        "initial: idel\n" + VALID,
        ["initial state 'idel' is not defined (did you mean 'idle'?)", "fix: define it or set 'initial:'"],
    ),
    "timeouts not a mapping": (
        "timeouts: 3\n" + VALID,
        ["timeouts: must be a mapping", "fix: write timeouts as a mapping, e.g. timeouts: {connect: 2.0"],
    ),
    "timeout not a number": (
        "timeouts: {connect: fast}\n" + VALID,
        [
            "timeouts > connect: must be a number, not the text 'fast'",
            "fix: write it as a number, e.g. connect: 2.0 (seconds to wait for a module's action server)",
        ],
    ),
    "timeout not positive": (
        "timeouts: {preempt: -1}\n" + VALID,
        [
            "timeouts > preempt: must be greater than or equal to 0.1, not the number -1",
            "fix: use a number of at least 0.1",
        ],
    ),
    "unknown transition target": (
        VALID.replace("music_play: music", "music_play: musik"),
        [
            "state 'idle': transition 'music_play' leads to unknown state 'musik' (did you mean 'music'?)",
            "fix: use one of idle, music",
        ],
    ),
    "no aborted transition": (
        VALID.replace("{succeeded: idle, aborted: idle}", "{succeeded: idle}"),
        ["state 'music': no 'aborted' transition", "fix: add 'aborted: idle' to its transitions"],
    ),
    "state name used on two levels": (
        GROUPED.replace("inner: {action: a/inner}", "idle: {action: b/idle}"),
        [
            "state 'idle': defined twice, at the top level and inside 'group'",
            "fix: state names must be unique across all levels",
        ],
    ),
    "state without action or substates": (
        VALID.replace("action: cyborg_music/play", "description: none"),
        ["state 'music': has no action; fix: add 'action: <module>/<server>'"],
    ),
    "state with action and substates": (
        GROUPED.replace("    transitions: {aborted: idle}\n    states:", "    action: a/g\n    states:"),
        ["state 'group': has both an action and substates", "fix: a state is either served by a module"],
    ),
    "initial substate not a substate": (
        GROUPED.replace("    states:", "    initial: idle\n    states:"),
        ["state 'group': initial substate 'idle' is not one of its substates (inner); fix: name one of them"],
    ),
    "initial on a state without substates": (
        _in_music("    initial: idle\n"),
        ["state 'music': sets initial 'idle' but has no substates; fix: remove 'initial:'"],
    ),
    "emotion value not a number": (
        VALID + "emotion: {decay_rate: fast}\n",
        [
            "emotion > decay_rate: must be a number, not the text 'fast'",
            "fix: write it as a number, e.g. decay_rate: 0.15",
        ],
    ),
    "emotion value out of range": (
        VALID + "emotion: {decay_rate: 3}\n",
        [
            "emotion > decay_rate: must be less than or equal to 1, not the number 3",
            "fix: use a number of at most 1",
        ],
    ),
    "prototype with two numbers": (
        VALID + "emotion: {prototypes: {happy: [0.5, 0.4]}}\n",
        ["emotion > prototypes > happy: has too few numbers", "fix: give three numbers in [-1, 1]"],
    ),
    "prototype named neutral": (
        VALID + "emotion: {prototypes: {neutral: [0, 0, 0]}}\n",
        ["emotion > prototypes: prototype 'neutral' is reserved", "fix: remove it"],
    ),
    "motivator selection unknown": (
        VALID + "motivator: {selection: best}\n",
        ["motivator > selection: must be ", "'net'", "'reward'", "not the text 'best'; fix: use one of "],
    ),
    "motivator events not a list": (
        VALID + "motivator: {events: {state: idle}}\n",
        ["motivator > events: must be a list", "fix: write events as a list, e.g. events: [{state: idle"],
    ),
    "motivational event without event": (
        VALID + "motivator: {events: [{state: idle}]}\n",
        [
            "motivator > events > entry 1 > event: missing 'event'",
            "fix: name a transition of that state, e.g. event: music_play",
        ],
    ),
    "motivational event not a transition": (
        VALID + "motivator: {events: [{state: music, event: dance}]}\n",
        [
            "motivator event 'dance' is no transition of state 'music'",
            "fix: add 'dance: <target>' to its transitions or use one of: aborted, succeeded",
        ],
    ),
    "motivational event in an unknown state": (
        VALID + "motivator: {events: [{state: nowhere, event: music_play}]}\n",
        ["motivator event 'music_play': state 'nowhere' is not defined; fix: name a defined state"],
    ),
    "modules not a mapping": (
        VALID + "modules: [cyborg_idle]\n",
        ["modules: must be a mapping", "fix: write modules as a mapping node name: settings"],
    ),
    "gatekeepers not a list": (
        VALID + "gatekeepers: {name: g}\n",
        [
            "gatekeepers: must be a list, not a mapping",
            "fix: write gatekeepers as a list, e.g. gatekeepers: [{name:",
        ],
    ),
    "gatekeeper without input": (
        VALID + "gatekeepers: [{name: g, output: /out, resource: speech}]\n",
        [
            "gatekeepers > entry 1 > input: missing 'input' (topic the behaviour modules publish on)",
            "fix: add it (e.g. input: /text_to_speech)",
        ],
    ),
}


@pytest.mark.parametrize("case", list(MESSAGES))
def test_error_message_names_file_place_problem_and_fix(case: str) -> None:
    text, fragments = MESSAGES[case]
    with pytest.raises(ConfigError) as info:
        parse_config(text, source="machine.yaml")
    message = str(info.value)
    for fragment in fragments:
        assert fragment in message
    assert info.value.problems, message
    for problem in info.value.problems:
        assert "fix: " in problem, f"no fix in {problem!r}"
    assert message.startswith("machine.yaml: ")


def test_duplicate_event_advice_is_not_the_state_advice() -> None:
    text, _ = MESSAGES["same event twice in one state's transitions"]
    assert "unique name" not in problems(text)


def test_doc_pointer_is_true_and_the_doc_names_every_key() -> None:
    """Errors point to docs/configuration.md; it must exist and describe what the models accept."""
    from cyborg.app.config import ConfigModel, GatekeeperModel
    from cyborg.controller.config import StateModel, TimeoutsModel
    from cyborg.emotion.model import EmotionSettings, HalfLives
    from cyborg.motivator.logic import MotivationalEvent, MotivatorSettings

    doc_path = DOCS / "configuration.md"
    doc = doc_path.read_text(encoding="utf-8")
    models: list[Any] = [
        ConfigModel,
        StateModel,
        TimeoutsModel,
        GatekeeperModel,
        EmotionSettings,
        HalfLives,
        MotivatorSettings,
        MotivationalEvent,
    ]
    prose = re.sub(r"```.*?```", "", doc, flags=re.S)
    documented = {word for span in re.findall(r"`([^`]+)`", prose) for word in re.findall(r"\w+", span)}
    missing = [
        f"{model.__name__}.{name}"
        for model in models
        for name in model.model_fields
        if name not in documented
    ]
    assert missing == [], "docs/configuration.md does not mention these keys"
    wrong_defaults = []
    tables: dict[str, type[BaseModel]] = {
        "Top level": ConfigModel,
        "`emotion`": EmotionSettings,
        "`motivator`": MotivatorSettings,
    }
    for title, model in tables.items():
        section = doc.split(f"## {title}\n", 1)[1].split("\n## ", 1)[0]
        for key, written in re.findall(r"^\| `([\w.]+)` \| `([^`]+)` \|", section, re.M):
            owner: Any = model
            for part in key.split(".")[:-1]:
                owner = owner.model_fields[part].annotation
            default = owner.model_fields[key.split(".")[-1]].get_default(call_default_factory=True)
            default = getattr(default, "value", default)
            if yaml.safe_load(written) != default:
                wrong_defaults.append(f"{key}: doc says {written}, code says {default!r}")
    assert wrong_defaults == [], "docs/configuration.md gives wrong defaults"
    example = re.search(r"```yaml\n(.*?)```", doc, re.S)
    assert example is not None
    loaded = parse_config(example.group(1), source="docs/configuration.md")
    assert loaded.warnings == []


def test_valid_file_defaults_initial_to_idle() -> None:
    loaded = parse_config(VALID)
    assert loaded.machine.initial == "idle"
    assert loaded.machine.timeouts.connect == 2.0
    assert loaded.warnings == []


def test_aborted_inherited_from_superstate_is_enough() -> None:
    text = """
states:
  idle: {action: a/idle, transitions: {go: group, aborted: idle}}
  group:
    transitions: {aborted: idle}
    states:
      inner: {action: a/inner}
"""
    assert parse_config(text).machine.lookup("inner", "aborted") == "idle"


def test_all_problems_reported_at_once() -> None:
    text = VALID.replace("music_play: music", "music_play: nowhere").replace(
        "succeeded: idle, aborted: idle", "succeeded: gone"
    )
    message = problems(text)
    assert "'nowhere'" in message and "'gone'" in message


def test_unreachable_state_is_a_warning_not_an_error() -> None:
    text = (
        VALID
        + """
  lonely:
    action: cyborg_lonely/x
    transitions: {aborted: idle}
"""
    )
    loaded = parse_config(text, source="m.yaml")
    assert any("'lonely' is unreachable" in w for w in loaded.warnings)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="cannot read the file"):
        load_config(tmp_path / "missing.yaml")


def test_packaged_configs_are_valid() -> None:
    from cyborg.app.config import packaged_config

    for name in ("demo.yaml",):
        assert load_config(packaged_config(name)).machine.states


def test_motivational_event_must_be_a_transition_of_its_state() -> None:
    text = (
        VALID
        + """
motivator:
  events:
    - {state: idle, event: music_play, reward_pleasure: 0.1}
    - {state: music, event: dance, reward_arousal: 0.1}
    - {state: nowhere, event: music_play}
"""
    )
    message = problems(text)
    assert "motivator event 'dance' is no transition of state 'music'" in message
    assert "state 'nowhere' is not defined" in message
    assert "'music_play'" not in message.split("dance")[0]  # the valid one is not reported


def test_every_machine_problem_and_warning_names_its_line(tmp_path: Path) -> None:
    """An unknown target, a missing 'aborted' in a substate, a bad initial and an unreachable
    state: each message starts with the line of the part it is about, nested states included."""
    path = tmp_path / "robot.yaml"
    path.write_text(
        "initial: idle\n"  # 1
        "states:\n"  # 2
        "  idle:\n"  # 3
        "    action: a/idle\n"  # 4
        "    transitions:\n"  # 5
        "      go: nowhere\n"  # 6
        "      aborted: idle\n"  # 7
        "  group:\n"  # 8
        "    initial: missing\n"  # 9
        "    states:\n"  # 10
        "      inner:\n"  # 11
        "        action: a/inner\n",  # 12
        encoding="utf-8",
    )
    with pytest.raises(ConfigError) as caught:
        load_config(path)
    text = str(caught.value)
    assert "line 6: state 'idle': transition 'go' leads to unknown state 'nowhere'" in text
    assert "line 9: state 'group': initial substate 'missing'" in text
    path.write_text(
        "initial: idle\nstates:\n  idle:\n    action: a/idle\n    transitions: {aborted: idle}\n"
        "  group:\n    transitions: {aborted: idle}\n    states:\n      inner:\n        action: a/inner\n",
        encoding="utf-8",
    )
    warnings = load_config(path).warnings
    assert any("line 9: state 'inner' is unreachable" in w for w in warnings), warnings
