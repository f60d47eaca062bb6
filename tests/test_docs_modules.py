"""docs/modules.md ("your first module") works as written: its code blocks run here."""

from __future__ import annotations

import re
import tomllib
from typing import Any

from cyborg.app.checks import robot_warnings
from cyborg.app.config import parse_config
from cyborg.app.registry import module_kinds
from cyborg.sim.scenario import run_scenario
from cyborg.sim.script import parse_script
from tests.support.paths import DOCS

DOC = DOCS / "modules.md"
BLOCK = re.compile(r"^```(\w+)(?: (\w+))?\n(.*?)^```", re.S | re.M)


def blocks() -> list[tuple[str, str, str]]:
    return [(lang, tag or "", body) for lang, tag, body in BLOCK.findall(DOC.read_text(encoding="utf-8"))]


def test_every_block_of_the_page_is_of_a_kind_this_test_runs() -> None:
    kinds = {(lang, tag) for lang, tag, _ in blocks()}
    assert kinds <= {
        ("sh", ""),
        ("python", ""),
        ("python", "rospy"),
        ("toml", ""),
        ("yaml", "robot"),
        ("yaml", "scenario"),
    }
    assert ("python", "") in kinds and ("yaml", "scenario") in kinds


def test_the_page_from_the_module_to_a_passing_scenario() -> None:
    namespace: dict[str, Any] = {"__name__": "docs_modules"}
    robot_yaml = scenario_yaml = ""
    for lang, tag, body in blocks():
        if lang == "python" and tag == "":
            exec(compile(body, f"{DOC}:python", "exec"), namespace)  # the module, then its harness test
        elif lang == "python" and tag == "rospy":
            exec(compile(body, f"{DOC}:rospy", "exec"), {"__name__": "docs_rospy"})  # imports and classes
        elif lang == "toml":
            entry = tomllib.loads(body)["project"]["entry-points"]["cyborg.module_kinds"]
            assert entry == {"greeter": "greeter.module:KIND"}
        elif (lang, tag) == ("yaml", "robot"):
            robot_yaml = body
        elif (lang, tag) == ("yaml", "scenario"):
            scenario_yaml = body
    kinds = module_kinds({"greeter": namespace["KIND"]})
    config = parse_config(robot_yaml, source="docs/modules.md")
    kinds.check(config.model.modules, source=config.source)
    assert robot_warnings(config, kinds) == []
    records = run_scenario(config, parse_script(scenario_yaml, source="docs/modules.md"), kinds=kinds)
    assert any(r["type"] == "say" and r["text"] == "Morning!" for r in records)


def test_the_wire_table_names_every_topic_a_module_meets() -> None:
    from cyborg.transport import topics

    text = DOC.read_text(encoding="utf-8")
    for name in (
        topics.REGISTER_EVENT,
        topics.STATE_CHANGE,
        topics.EMOTIONAL_FEEDBACK,
        topics.EMOTIONAL_STATE,
        topics.GET_EMOTIONAL_STATE,
        topics.TEXT_FROM_SPEECH,
        topics.SPEECH_UNSURE,
        topics.TEXT_TO_SPEECH,
        topics.STATE_RESOURCES_PARAM,
        topics.TRANSITIONS_PARAM,
    ):
        assert f"`{name}`" in text, f"docs/modules.md does not list {name}"
