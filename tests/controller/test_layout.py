"""The layout one superstate at a time (issue 16): where arrows are drawn, that every state lands
inside its superstate's box, and that a big machine needs only a few Graphviz runs."""

from __future__ import annotations

import re

import pytest

from cyborg.app.config import load_config, packaged_config
from cyborg.controller.machine import MachineSpec
from cyborg.drawing.layout import (
    ROOT,
    START,
    Block,
    blocks_of,
    draw,
    is_dense,
    lay_out,
    machine_key,
    placing_arrows,
)
from cyborg.testing.machines import machine_spec, random_machine, structured


@pytest.fixture(scope="module")
def cyborg() -> MachineSpec:
    return load_config(packaged_config("cyborg.yaml")).machine


def test_arrows_are_drawn_in_the_innermost_superstate_that_holds_both_ends(cyborg: MachineSpec) -> None:
    blocks = blocks_of(cyborg)
    top = blocks[ROOT].arrows
    # conversation's five question events lead into the questions superstate: one arrow for all
    assert sorted(e for _, e in top[("conversation", "questions")]) == [
        "follower_follow",
        "joke_tell",
        "selfie_take",
        "simon_says_play",
        "weather_tell",
    ]
    assert ("questions", "succeeded") in top[("questions", "conversation")]  # the superstate's own
    inner = blocks["navigation"].arrows
    assert ("navigation_moving", "succeeded") in inner[("navigation_moving", "navigation_talking")]
    assert (START, "idle") in top and blocks[ROOT].members[0] == START
    # every transition is drawn exactly once
    drawn = sorted(pair for block in blocks.values() for pairs in block.arrows.values() for pair in pairs)
    declared = sorted((s.name, e) for s in cyborg.states.values() for e in s.transitions)
    assert drawn == declared


def test_every_state_is_drawn_inside_its_superstates_box(cyborg: MachineSpec) -> None:
    layout = lay_out(machine_spec(structured(120, seed=3)))
    boxes = {
        name: [float(v) for v in bb.split(",")]
        for name, bb in re.findall(r'subgraph "cluster_([^"]+)" \{\n\s*graph \[bb="([^"]+)"', layout.source)
    }
    spec = machine_spec(structured(120, seed=3))
    assert set(boxes) == {s.name for s in spec.states.values() if not s.is_leaf}
    nodes = dict(re.findall(r'^\s*"([^"]+)" \[pos="([^"]+)" width', layout.source, re.M))
    assert set(nodes) == {s.name for s in spec.leaves()}
    for name, pos in nodes.items():
        x, y = (float(v) for v in pos.split(","))
        for outer in spec.ancestors(name):
            if outer.name != name:
                left, bottom, right, top = boxes[outer.name]
                assert left < x < right and bottom < y < top, f"{name} is outside {outer.name}"
    siblings = [boxes[g] for g in boxes if g.startswith("group") and spec.states[g].parent is None]
    for i, a in enumerate(siblings):  # boxes side by side do not overlap
        for b in siblings[i + 1 :]:
            assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]


def test_the_drawing_has_the_ids_the_dashboard_reads(cyborg: MachineSpec) -> None:
    layout = lay_out(cyborg)
    svg = draw(layout).decode()
    for leaf in cyborg.leaves():
        assert f'id="state:{leaf.name}"' in svg
    assert 'id="super:questions"' in svg and 'id="super:navigation"' in svg
    assert 'id="edge:idle:music_play"' in svg
    assert layout.edges["edge:conversation:follower_follow"][0] == ("conversation", "follower_follow")
    assert ">5 events<" in svg  # five events on one arrow: counted, named in its tooltip
    assert "follower_follow, joke_tell, selfie_take, simon_says_play, weather_tell" in svg


def test_a_thousand_states_take_one_graphviz_run_per_depth() -> None:
    machine = machine_spec(structured(1000))
    layout = lay_out(machine)
    depths = {len(list(machine.ancestors(s.name))) for s in machine.states.values() if not s.is_leaf}
    assert layout.runs == len(depths) + 1 == 3
    assert len(re.findall(r'id="state:', layout.source)) == 1000


def test_a_dense_block_places_its_states_with_one_arrow_each() -> None:
    machine = machine_spec(random_machine(300, seed=1))
    top = blocks_of(machine)[ROOT]
    assert is_dense(top)
    placing = placing_arrows(top)
    between = [(tail, head) for tail, head in placing if tail != head]
    assert len({tail for tail, _ in between}) == len(between) <= len(top.members)
    sparse = Block("x", 1, ["a", "b"], {("a", "b"): [("a", "go")]})
    assert placing_arrows(sparse) == sparse.arrows
    layout = lay_out(machine)  # the other arrows are drawn straight, still with their ids
    assert len(layout.edges) == sum(1 for b in blocks_of(machine).values() for p in b.arrows.values() if p)


def test_the_cache_key_follows_what_is_drawn(cyborg: MachineSpec) -> None:
    assert machine_key(cyborg) == machine_key(load_config(packaged_config("cyborg.yaml")).machine)
    assert machine_key(machine_spec(structured(50, seed=1))) != machine_key(
        machine_spec(structured(50, seed=2))
    )


def test_the_shipped_machine_is_drawn_about_as_wide_as_the_dashboard_panel(cyborg: MachineSpec) -> None:
    """At 1280x800 the graph panel is about 786x274 px; one long line of events per arrow made the
    drawing 2799x523 pt (5.4:1), its names 5 px high. Now each direction is tried per block, arrows
    list at most two events, and the five questions (no arrows among them) sit in a grid."""
    svg = draw(lay_out(cyborg)).decode()
    found = re.search(r'<svg width="([\d.]+)pt" height="([\d.]+)pt"', svg)
    assert found is not None
    width, height = float(found.group(1)), float(found.group(2))
    assert width / height < 3.6, f"{width:.0f}x{height:.0f} pt: too wide for the panel"
    scale = min(786 / width, 274 / height)  # px per pt, fitted to the panel
    assert 16 * scale >= 9, f"state names {16 * scale:.1f} px at 1280x800"
    questions = [
        tuple(float(v) for v in pos.split(","))
        for pos in re.findall(
            r'"(?:joke|weather|selfie|follower|simon_says)" \[pos="([^"]+)"', lay_out(cyborg).source
        )
    ]
    assert len({x for x, _ in questions}) >= 2 and len({y for _, y in questions}) >= 2, "a grid"
