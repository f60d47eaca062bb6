"""Draw the state machine with Graphviz (the layout is Graphviz's, not ours).

Superstates become clusters; their transitions are drawn from the cluster's
border. The active state can be highlighted (the dashboard uses that).
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import graphviz

from cyborg.controller.machine import MachineSpec, StateSpec
from cyborg.errors import CyborgError

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
    """Write ``output`` as .dot (no Graphviz needed) or any format ``dot`` renders (.svg, .png, .pdf)."""
    graph = to_graph(machine, active=active)
    suffix = output.suffix.lstrip(".").lower()
    if suffix in ("dot", "gv"):
        output.write_text(graph.source, encoding="utf-8")
        return output
    output.write_bytes(render_bytes(graph, suffix or "svg"))
    return output


def render_bytes(graph: graphviz.Digraph, fmt: str = "svg") -> bytes:
    if shutil.which("dot") is None:
        raise CyborgError(
            "Graphviz's 'dot' program is not installed, so the graph cannot be rendered; "
            "fix: install it (apt-get install graphviz) or write a .dot file instead"
        )
    try:
        done = subprocess.run(
            ["dot", f"-T{fmt}"], input=graph.source.encode(), capture_output=True, check=True
        )
    except subprocess.CalledProcessError as exc:
        raise CyborgError(
            f"Graphviz could not render format {fmt!r}: {exc.stderr.decode().strip()}; fix: use svg, png or pdf"
        ) from exc
    return bytes(done.stdout)
