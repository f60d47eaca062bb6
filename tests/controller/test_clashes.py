"""Parallel states in the YAML: their validation and the static check of exclusive resources."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from click.testing import CliRunner

from cyborg.app.config import parse_config
from cyborg.cli import cli
from cyborg.controller.clashes import _Tables, explore
from cyborg.controller.machine import ABORTED, SUCCEEDED
from cyborg.controller.regions import Regions
from cyborg.errors import ConfigError

# The behaviour region needs two steps to reach music (idle -> chat -> music) or one via
# `play`; the monitor reaches greet with `face_seen`. Speaker in music and greet: a clash.
PLANTED = """
initial: idle
states:
  idle:
    action: m/idle
    transitions: {go: busy, aborted: idle}
  busy:
    parallel: true
    transitions: {stop: idle, aborted: idle}
    states:
      behaviour:
        priority: 1
        states:
          rest: {action: m/rest, transitions: {chat_start: chat, play: music}}
          chat: {action: m/chat, transitions: {succeeded: music}}
          music: {action: m/music, resources: {speaker: music_node}, transitions: {succeeded: rest}}
      monitor:
        priority: 10
        states:
          ok: {action: m/ok, transitions: {face_seen: greet, battery_low: warning}}
          greet: {action: m/greet, resources: {speaker: greet_node}, transitions: {succeeded: ok}}
          warning: {action: m/warn, resources: {speech: warn_node}, transitions: {succeeded: ok}}
"""


def problems(text: str) -> list[str]:
    with pytest.raises(ConfigError) as caught:
        parse_config(text)
    return caught.value.problems


def test_a_planted_clash_is_found_with_its_shortest_trace() -> None:
    (problem,) = problems(PLANTED)
    assert problem == (
        "line 7: parallel state 'busy': regions 'monitor' and 'behaviour' both hold the "
        "exclusive resource 'speaker' (states 'greet' and 'music'), reached by start -> go -> face_seen "
        "-> play; fix: grant 'speaker' in one region only, or let the higher-priority region win it "
        "with resource_policy: {speaker: arbitrated}"
    )


def test_a_clash_reached_only_through_a_modules_result_names_that_result() -> None:
    text = PLANTED.replace(", play: music", "")
    (problem,) = problems(text)
    assert "reached by start -> go -> face_seen -> chat_start -> chat: succeeded;" in problem


def test_arbitrating_the_resource_or_granting_it_once_passes() -> None:
    arbitrated = parse_config(
        PLANTED.replace("states:\n  idle:", "resource_policy: {speaker: arbitrated}\nstates:\n  idle:", 1)
    )
    exploration = explore(arbitrated.machine)
    assert exploration.clashes == ()
    assert exploration.parallel_configurations == 9  # 3 x 3, all reachable
    assert exploration.configurations == 10
    once = parse_config(PLANTED.replace("resources: {speaker: greet_node}, ", ""))
    assert explore(once.machine).clashes == ()


def test_an_unreachable_clash_is_no_clash() -> None:
    text = PLANTED.replace("chat_start: chat, play: music", "chat_start: chat").replace(
        "chat: {action: m/chat, transitions: {succeeded: music}}",
        "chat: {action: m/chat, transitions: {succeeded: rest}}",
    )
    loaded = parse_config(text)
    assert explore(loaded.machine).clashes == ()
    assert any("'music' is unreachable" in w for w in loaded.warnings)


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (
            "        priority: 10\n",
            "region of parallel state 'busy' without a priority; fix: add 'priority: ",
        ),
        ("priority: 10", "has the same priority (1) as region 'behaviour'"),
        ("face_seen: greet,", "transition 'face_seen' leads from region 'monitor' into region 'behaviour'"),
        (
            "    parallel: true\n",
            "sets priority 1 but is no region of a parallel state; fix: remove 'priority:'",
        ),
        ("    parallel: true\n", "sets priority 10 but is no region"),
    ],
)
def test_bad_parallel_states_are_refused_with_what_and_how_to_fix(change: str, expected: str) -> None:
    replacement = {
        "        priority: 10\n": "",
        "priority: 10": "priority: 1",
        "face_seen: greet,": "face_seen: chat,",
        "    parallel: true\n": "",
    }[change]
    found = problems(PLANTED.replace(change, replacement))
    assert any(expected in p and "; fix: " in p for p in found), found


def test_nested_single_region_and_initial_parallel_states_are_refused() -> None:
    nested = PLANTED.replace(
        "      behaviour:\n        priority: 1\n",
        "      behaviour:\n        priority: 1\n        parallel: true\n",
    )
    assert any("a parallel state inside parallel state 'busy'; fix:" in p for p in problems(nested))
    single = PLANTED.split("      monitor:")[0]
    assert any("parallel with 1 region(s); fix:" in p for p in problems(single))
    initial = PLANTED.replace("    parallel: true\n", "    parallel: true\n    initial: monitor\n")
    assert any(
        "a parallel state sets initial 'monitor'; fix: remove 'initial:'" in p for p in problems(initial)
    )
    policy = problems(
        PLANTED.replace("states:\n  idle:", "resource_policy: {speaker: shared}\nstates:\n  idle:", 1)
    )
    assert any("resource_policy" in p and "exclusive" in p and "fix" in p for p in policy), policy


def test_cyborg_validate_reports_the_clash_and_exits_one(tmp_path: Path) -> None:
    path = tmp_path / "busy.yaml"
    path.write_text(PLANTED)
    result = CliRunner().invoke(cli, ["validate", str(path)])
    assert result.exit_code == 1
    assert "reached by start -> go -> face_seen -> play; fix: " in result.output
    path.write_text(
        PLANTED.replace("states:\n  idle:", "resource_policy: {speaker: arbitrated}\nstates:\n  idle:", 1)
    )
    result = CliRunner().invoke(cli, ["validate", str(path)])
    assert result.exit_code == 0, result.output
    assert (
        "parallel state(s): 9 combinations of their regions' states reachable, no exclusive clash"
        in result.output
    )


def _stepped(regions: Regions, config: tuple[str, ...]) -> set[tuple[str, str | None, tuple[str, ...]]]:
    """Every (event, source, next configuration) from ``config`` by Regions.step, the controller's own rule."""
    machine = regions.machine
    out: set[tuple[str, str | None, tuple[str, ...]]] = set()
    for event in {e for leaf in config for e in machine.transitions_of(leaf)}:
        step = regions.step(config, event)
        if step is not None:
            out.add((event, None, step.leaves))
    for leaf in config:
        for result in (SUCCEEDED, ABORTED):
            step = regions.step(config, result, leaf) or regions.step(config, ABORTED, leaf)
            if step is not None:
                out.add((result, leaf, step.leaves))
    return out


@pytest.mark.parametrize(("seed", "count"), [(seed, count) for seed in range(4) for count in (2, 3)])
def test_the_check_reaches_exactly_what_the_controller_can(seed: int, count: int) -> None:
    rng = random.Random(seed)
    alphabet = ["a", "b", "c", "d", "stop", "aborted", "succeeded"]

    def region(prefix: str, count: int, priority: int) -> str:
        lines = [f"      {prefix}:", f"        priority: {priority}", "        states:"]
        for i in range(count):
            targets = [f"{prefix}{rng.randrange(count)}" for _ in range(3)]
            if rng.random() < 0.2:
                targets[0] = "idle"  # a region's transition out of the parallel state
            events = rng.sample(alphabet, 3)
            moves = ", ".join(f"{e}: {t}" for e, t in zip(events, targets, strict=True))
            lines.append(f"          {prefix}{i}: {{action: m/{prefix}{i}, transitions: {{{moves}}}}}")
        return "\n".join(lines)

    text = (
        "states:\n  idle: {action: m/idle, transitions: {go: busy, a: x1, aborted: idle}}\n"
        "  busy:\n    parallel: true\n    transitions: {stop: idle, aborted: idle}\n    states:\n"
        f"{region('x', 6, 1)}\n{region('y', 5, 2)}\n" + (f"{region('z', 3, 3)}\n" if count == 3 else "")
    )
    machine = parse_config(text).machine
    regions = Regions(machine)
    tables = _Tables(machine, regions)
    start = regions.configuration(machine.enter(machine.initial))
    seen, queue = {start}, [start]
    while queue:  # every reachable configuration: the check's moves are exactly the controller's
        config = queue.pop()
        expected = _stepped(regions, config)
        if len(config) > 1:
            found = set(tables.successors(config))
            assert {(e, src, nxt) for e, src, nxt in found if src is not None} == {
                m for m in expected if m[1] is not None
            }, config
            assert {(e, nxt) for e, src, nxt in found if src is None} == {
                (e, nxt) for e, src, nxt in expected if src is None
            }, config
        for _, _, following in expected:
            if following not in seen:
                seen.add(following)
                queue.append(following)
    exploration = explore(machine)
    assert exploration.configurations == len(seen)
    assert exploration.parallel_configurations == sum(1 for c in seen if len(c) > 1) > 10


def test_a_policy_for_a_resource_no_state_grants_is_a_warning_with_the_likely_name() -> None:
    loaded = parse_config(
        "resource_policy: {speakr: arbitrated}\n"
        "states:\n  idle: {action: a/b, transitions: {aborted: idle}, resources: {speaker: n}}\n"
    )
    assert loaded.warnings == [
        "<config>: line 1: resource_policy names 'speakr', which no state grants (did you mean "
        "'speaker'?); fix: correct its spelling or remove it"
    ]
