"""Draw the state machine with Graphviz.

:func:`to_graph` describes the machine for Graphviz to lay out in one go (the .dot that
`cyborg graph` writes); :func:`render` draws it laid out one superstate at a time, which stays
fast as the machine grows (:mod:`cyborg.drawing.layout`). Superstates become clusters; the
active state can be highlighted. :func:`list_svg` lists the states where no graph can be drawn.
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import graphviz

from cyborg.controller.machine import MachineSpec, StateSpec
from cyborg.drawing.layout import draw, lay_out
from cyborg.errors import InvalidValueError

__all__ = ["ACTIVE_FILL", "list_svg", "render", "to_graph"]

ACTIVE_FILL = "#7bd389"


def to_graph(
    machine: MachineSpec, *, active: str | None = None, last_transition: tuple[str, str] | None = None
) -> graphviz.Digraph:
    """Build a Graphviz digraph of ``machine``."""
    dot = graphviz.Digraph(
        "state_machine", graph_attr={"rankdir": "LR", "compound": "true", "fontname": "Helvetica"}
    )
    dot.attr("node", shape="box", style="rounded,filled", fillcolor="#f4f4f4", fontname="Helvetica")
    dot.attr("edge", fontname="Helvetica", fontsize="10")
    dot.node("__start", label="", shape="point", width="0.15", fillcolor="black")
    for state in machine.states.values():
        if state.parent is None:
            _add_state(dot, machine, state, active)
    dot.edge("__start", machine.enter(machine.initial))
    for state in machine.states.values():
        for event, target in state.transitions.items():
            attrs: dict[str, str] = {"label": event, "id": f"edge:{state.name}:{event}"}
            tail = state.name
            if not state.is_leaf:
                tail = _first_leaf(machine, state)
                attrs["ltail"] = f"cluster_{state.name}"
            head = machine.enter(target)
            if not machine.states[target].is_leaf:
                attrs["lhead"] = f"cluster_{target}"
            if last_transition == (state.name, event) or (
                last_transition is not None
                and last_transition[1] == event
                and last_transition[0] in _leaves_under(machine, state)
            ):
                attrs.update(color="#d1495b", penwidth="2.5", fontcolor="#d1495b")
            dot.edge(tail, head, **attrs)
    return dot


def _add_state(dot: graphviz.Digraph, machine: MachineSpec, state: StateSpec, active: str | None) -> None:
    if state.is_leaf:
        attrs = {"id": f"state:{state.name}", "tooltip": state.action or ""}
        if state.name == active:
            attrs.update(fillcolor=ACTIVE_FILL, penwidth="2")
        dot.node(state.name, label=state.name, **attrs)
        return
    with dot.subgraph(name=f"cluster_{state.name}") as sub:
        sub.attr(label=state.name, style="rounded,dashed", color="#888888", id=f"super:{state.name}")
        for child in state.children:
            _add_state(sub, machine, machine.states[child], active)


def _first_leaf(machine: MachineSpec, state: StateSpec) -> str:
    return machine.enter(state.name)


def _leaves_under(machine: MachineSpec, state: StateSpec) -> set[str]:
    if state.is_leaf:
        return {state.name}
    leaves: set[str] = set()
    for child in state.children:
        leaves |= _leaves_under(machine, machine.states[child])
    return leaves


def render(machine: MachineSpec, output: Path, *, active: str | None = None) -> Path:
    """Write ``output`` as .dot (the machine for Graphviz to lay out; no Graphviz needed) or, laid
    out one superstate at a time (:mod:`cyborg.drawing.layout`), as .svg, .png or .pdf."""
    suffix = output.suffix.lstrip(".").lower()
    if suffix in ("dot", "gv"):
        output.write_text(to_graph(machine, active=active).source, encoding="utf-8")
        return output
    if suffix not in ("svg", "png", "pdf"):
        raise InvalidValueError(
            f"cannot draw the machine as {output.name!r}; fix: name a .svg, .png, .pdf or .dot file"
        )
    output.write_bytes(draw(lay_out(machine), suffix))
    return output


def list_svg(machine: MachineSpec, note: str) -> bytes:
    """The machine as a readable list instead of a graph: one box per leaf state, its transitions
    beside it, in columns; ``note`` on top says why. Boxes have the ids ``state:<name>`` (and the
    classes) of Graphviz's nodes, so the dashboard highlights the active state as on the graph."""
    per_column, row, width, gap = 40, 22, 360, 24
    leaves = [state.name for state in machine.leaves()]
    rows: list[str] = []
    for index, state in enumerate(leaves):
        x = 10 + (index // per_column) * (width + gap)
        y = 48 + (index % per_column) * row
        transitions = ", ".join(
            f"{event} \u2192 {target}" for event, target in machine.transitions_of(state).items()
        )
        rows.append(
            f'<g id={quoteattr("state:" + state)} class="node"><title>{escape(state)}</title>'
            f'<polygon points="{x},{y} {x + width},{y} {x + width},{y + row - 4} {x},{y + row - 4}"/>'
            f'<text x="{x + 6}" y="{y + 13}" font-size="12">{escape(state)}'
            f'<tspan font-size="9" dx="8">{escape(transitions)}</tspan></text></g>'
        )
    columns = max(1, -(-len(leaves) // per_column))
    total_width = 20 + columns * (width + gap)
    total_height = 60 + min(len(leaves), per_column) * row
    return (
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{total_width}pt" height="{total_height}pt" '
        f'viewBox="0 0 {total_width} {total_height}" font-family="Helvetica,sans-serif">'
        f'<g class="graph" id="list"><text x="10" y="24" font-size="14" fill="#8a93a3">{escape(note)}</text>'
        + "".join(rows)
        + "</g></svg>"
    ).encode()
