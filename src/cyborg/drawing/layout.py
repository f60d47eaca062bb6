"""Lay out a state machine of any size with Graphviz, one superstate at a time.

Graphviz's ``dot`` lays a whole machine with clusters out in one go, and that grows much faster
than the machine (minutes at 100 states, gigabytes at 1,000; docs/benchmarks-history.md). A superstate is
a box whose inside does not depend on the outside, so here each superstate's contents are laid out
on their own (a *block*: its substates, superstates inside it as boxes of the size their own block
needs) and the blocks are put together: the innermost first, all blocks of one depth in one ``dot``
run. A transition is drawn in the innermost block that holds both of its ends, between the boxes
that hold them; transitions between the same two boxes share one arrow, labelled with up to two
events (one a line) or how many. Each block is laid out in both directions and the better fit kept.
The drawing is handed to Graphviz once more with every position fixed (``neato -n2``), so the
output is Graphviz's own (SVG, PNG or PDF) with the ids the dashboard reads: ``state:<leaf>``,
``super:<superstate>`` and, per arrow, ``edge:<state>:<event>`` of the first transition it shows.

The building of the blocks, their sources and the putting together are pure (tested without
Graphviz); :func:`lay_out` runs the programs.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import resource
import shutil
import subprocess
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

from cyborg.controller.machine import MachineSpec, StateSpec
from cyborg.errors import CyborgError

__all__ = [
    "Block",
    "Layout",
    "block_source",
    "blocks_of",
    "compose",
    "lay_out",
    "machine_key",
    "parse_json_graphs",
    "run_graphviz",
]

ROOT = ""  # the block of the top level
START = "__start"
PAD = 10.0  # points between a superstate's border and its contents
LABEL = 24.0  # points of a superstate's title line
CHAR = 8.0  # points per character of a superstate's title, for its width
# An arrow's label lists up to this many events, one a line; with more it counts them ("5 events"),
# all of them in its tooltip. One long line of events made the shipped machine's drawing five times
# as wide as high and its names unreadable at first view (docs/benchmarks-history.md).
MAX_LABEL_EVENTS = 2
# A block with more arrows than this (per state in it) is dense: only each state's first arrow
# places the states, and the others are drawn straight and unlabelled (their events in a tooltip).
DENSE_PER_STATE = 2.0
# Per block: a layered layout, crossing minimisation and network simplex bounded, so a dense
# block cannot take minutes (docs/benchmarks-history.md, "Drawing the state machine as it grows");
# states and ranks closer than dot's defaults (0.25 and 0.5 inches).
DOT_ARGS = [
    "-Gmclimit=0.5",
    "-Gnslimit=5",
    "-Gnslimit1=5",
    "-Gsearchsize=30",
    "-Gnodesep=0.15",
    "-Granksep=0.3",
]
# Each block is laid out left to right and top to bottom (two dot processes side by side) and the one kept
# that fits its place best: the whole machine the dashboard's graph panel, about ASPECT times as
# wide as high (1280x800 and 1400x900 windows), a superstate's box a square (see ``choose``).
DIRECTIONS = ("LR", "TB")
ASPECT = 2.7
# State names a little larger than Graphviz's 14 points (events are 10): they are what one reads first.
NODE_STYLE = 'shape=box style="rounded,filled" fillcolor="#f4f4f4" fontname=Helvetica fontsize=16'


@dataclass
class Block:
    """One superstate's contents (``owner`` is ``""`` for the top level): the states directly in
    it and its arrows, (tail, head) -> the (state, event) transitions the arrow stands for."""

    owner: str
    depth: int
    members: list[str] = field(default_factory=list)
    arrows: dict[tuple[str, str], list[tuple[str, str]]] = field(default_factory=dict)


@dataclass(frozen=True)
class Layout:
    """A machine laid out: ``source`` is Graphviz's input with every position fixed, ``edges``
    maps each arrow's id to the (state, event) transitions it shows, ``seconds`` the time taken."""

    source: str
    edges: dict[str, list[tuple[str, str]]]
    seconds: float
    runs: int


def machine_key(machine: MachineSpec) -> str:
    """A hash of everything the drawing shows of ``machine`` (so equal machines share a layout)."""
    shape = [
        (s.name, s.parent, s.action, s.initial, sorted(s.transitions.items()))
        for s in sorted(machine.states.values(), key=lambda state: state.name)
    ]
    text = json.dumps([machine.initial, shape], separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _chain(machine: MachineSpec, name: str) -> list[str]:
    """``name``, then its superstates outwards, then the top level ``""``."""
    return [state.name for state in machine.ancestors(name)] + [ROOT]


def blocks_of(machine: MachineSpec) -> dict[str, Block]:
    """The blocks of ``machine``: one per superstate and one for the top level, with their arrows."""
    blocks = {ROOT: Block(ROOT, 0)}
    for state in machine.states.values():
        if not state.is_leaf:
            blocks[state.name] = Block(state.name, len(_chain(machine, state.name)) - 1)
    for state in machine.states.values():
        blocks[state.parent or ROOT].members.append(state.name)
    for state in machine.states.values():
        for event, target in state.transitions.items():
            tail_chain = _chain(machine, state.name)
            strict = set(_chain(machine, target)[1:])  # the blocks that hold the target
            index = next(i for i in range(1, len(tail_chain)) if tail_chain[i] in strict)
            owner = tail_chain[index]
            tail = tail_chain[index - 1]
            head_chain = _chain(machine, target)
            head = head_chain[head_chain.index(owner) - 1]
            blocks[owner].arrows.setdefault((tail, head), []).append((state.name, event))
    top = _chain(machine, machine.initial)[-2]
    blocks[ROOT].members.insert(0, START)
    blocks[ROOT].arrows[(START, top)] = []
    return blocks


def _quote(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _arrow_label(pairs: list[tuple[str, str]]) -> list[str]:
    """The lines of an arrow's label: its events, or how many there are."""
    events = sorted({event for _, event in pairs})
    return events if len(events) <= MAX_LABEL_EVENTS else [f"{len(events)} events"]


def _label(lines: list[str]) -> str:
    """A Graphviz label of ``lines``, each centred."""
    return '"' + "\\n".join(line.replace("\\", "\\\\").replace('"', '\\"') for line in lines) + '"'


def _arrow_id(tail: str, head: str, pairs: list[tuple[str, str]]) -> str:
    if not pairs:
        return f"edge:{START}"
    state, event = min(pairs)
    return f"edge:{state}:{event}"


def block_source(
    block: Block, machine: MachineSpec, sizes: dict[str, tuple[float, float]], rankdir: str = "LR"
) -> str:
    """The ``dot`` input of one block, its ranks in direction ``rankdir``; ``sizes`` gives the
    width and height (points) of each superstate in it (from its own block)."""
    lines = [
        f"digraph {_quote('block:' + block.owner)} {{",
        f"rankdir={rankdir};",
        f"node [{NODE_STYLE}];",
        "edge [fontname=Helvetica fontsize=10];",
    ]
    for name in block.members:
        if name == START:
            lines.append(f'{START} [shape=point width=0.15 label=""];')
        elif machine.states[name].is_leaf:
            lines.append(f"{_quote(name)};")
        else:
            width, height = sizes[name]
            lines.append(
                f'{_quote(name)} [shape=box fixedsize=true label="" width={width / 72:.3f} height={height / 72:.3f}];'
            )
    placing = placing_arrows(block)
    for (tail, head), pairs in placing.items():
        label = _arrow_label(pairs)
        attrs = f"id={_quote(_arrow_id(tail, head, pairs))}" + (f" label={_label(label)}" if label else "")
        lines.append(f"{_quote(tail)} -> {_quote(head)} [{attrs}];")
    for tail, head in grid_links(block, placing):
        lines.append(f"{_quote(tail)} -> {_quote(head)} [style=invis];")
    lines.append("}")
    return "\n".join(lines) + "\n"


def grid_links(block: Block, placing: dict[tuple[str, str], list[tuple[str, str]]]) -> list[tuple[str, str]]:
    """Invisible links that put the states of ``block`` without an arrow among them in a grid
    (lines of about the square root of their number, rows or columns by the direction) instead of
    one long line: the five questions of the shipped machine each have only the superstate's arrows."""
    linked = {end for arrow in placing for end in arrow}
    alone = [name for name in block.members if name != START and name not in linked]
    if len(alone) < 3:
        return []
    row = math.ceil(math.sqrt(len(alone)))
    return [(alone[i - 1], alone[i]) for i in range(1, len(alone)) if i % row]


def is_dense(block: Block) -> bool:
    """Whether ``block`` has too many arrows to lay all of them out (see ``DENSE_PER_STATE``)."""
    return len(block.arrows) > DENSE_PER_STATE * len(block.members) + 10


def placing_arrows(block: Block) -> dict[tuple[str, str], list[tuple[str, str]]]:
    """The arrows Graphviz lays out in ``block``: all of them, or in a dense block each state's
    first and the loops."""
    if not is_dense(block):
        return block.arrows
    first: dict[str, tuple[str, str]] = {}
    loops = [(tail, head) for tail, head in block.arrows if tail == head]  # cheap, and drawn labelled
    for tail, head in sorted(block.arrows):
        if tail != head:
            first.setdefault(tail, (tail, head))
    return {arrow: block.arrows[arrow] for arrow in [*first.values(), *loops]}


@dataclass
class _Laid:
    """One block as Graphviz laid it out (points, y up, lower left corner at 0,0)."""

    width: float
    height: float
    nodes: dict[str, tuple[float, float, float, float]]  # name -> x, y, width, height
    edges: list[tuple[str, str, str, str, str]]  # tail, head, id, pos, label position


def parse_json_graphs(text: str) -> Iterator[dict[str, Any]]:
    """The graphs of Graphviz's ``-Tjson0`` output for several graphs (one JSON object each)."""
    decoder = json.JSONDecoder()
    index = 0
    while True:
        while index < len(text) and text[index].isspace():
            index += 1
        if index >= len(text):
            return
        graph, index = decoder.raw_decode(text, index)
        yield graph


def _laid(graph: dict[str, Any]) -> _Laid:
    bb = [float(v) for v in str(graph["bb"]).split(",")]
    objects: list[dict[str, Any]] = graph.get("objects", [])
    names: dict[int, str] = {}
    nodes: dict[str, tuple[float, float, float, float]] = {}
    for item in objects:
        names[item["_gvid"]] = item["name"]
        x, y = (float(v) for v in item["pos"].split(","))
        nodes[item["name"]] = (x, y, float(item["width"]) * 72, float(item["height"]) * 72)
    edges = []
    for item in graph.get("edges", []) or []:
        edges.append(
            (names[item["tail"]], names[item["head"]], item.get("id", ""), item["pos"], item.get("lp", ""))
        )
    return _Laid(bb[2] - bb[0], bb[3] - bb[1], nodes, edges)


def _shift(points: str, dx: float, dy: float) -> str:
    """A Graphviz point list (``e,x,y x,y ...``) moved by (dx, dy)."""
    out = []
    for point in points.split():
        prefix = ""
        if point[:2] in ("e,", "s,"):
            prefix, point = point[:2], point[2:]
        x, y = point.split(",")
        out.append(f"{prefix}{float(x) + dx:.2f},{float(y) + dy:.2f}")
    return " ".join(out)


def choose(owner: str, options: list[_Laid]) -> _Laid:
    """Of one block's layouts (one per direction), the one that fits its place best: for the top
    level the one shown biggest in a panel ``ASPECT`` times as wide as high, for a superstate the
    one whose box is the most nearly square (it is one box among others in the block around it,
    and what the dashboard zooms to when it opens the superstate)."""
    if owner == ROOT:
        return max(options, key=lambda laid: min(ASPECT / max(laid.width, 1.0), 1 / max(laid.height, 1.0)))

    def elongation(laid: _Laid) -> float:
        width, height = box_size(laid.width, laid.height, owner)
        return max(width / height, height / width)

    return min(options, key=elongation)


def _box_style(machine: MachineSpec, state: StateSpec) -> str:
    """A superstate's border: dashed; a parallel state's bold, its regions' dotted (docs/parallel.md)."""
    if state.parallel:
        return "rounded,bold"
    if state.parent is not None and machine.states[state.parent].parallel:
        return "rounded,dotted"
    return "rounded,dashed"


def box_size(laid_width: float, laid_height: float, title: str) -> tuple[float, float]:
    """The box (points) a superstate needs around its laid out contents and its title."""
    return max(laid_width + 2 * PAD, len(title) * CHAR + 2 * PAD), laid_height + 2 * PAD + LABEL


def compose(
    machine: MachineSpec, blocks: dict[str, Block], laid: dict[str, _Laid]
) -> tuple[str, dict[str, list[tuple[str, str]]]]:
    """The whole drawing with every position fixed (input for ``neato -n2``), and each arrow's
    transitions by arrow id."""
    top = laid[ROOT]
    edges: dict[str, list[tuple[str, str]]] = {}
    out = [
        "digraph state_machine {",
        f'graph [bb="0,0,{top.width:.2f},{top.height:.2f}" fontname=Helvetica];',
        f"node [{NODE_STYLE}];",
        "edge [fontname=Helvetica fontsize=10];",
    ]
    arrows = {
        owner: {(t, h): pairs for (t, h), pairs in block.arrows.items()} for owner, block in blocks.items()
    }
    edge_lines: list[str] = []

    def place(owner: str, dx: float, dy: float, indent: str) -> None:
        block = laid[owner]
        for name, (x, y, w, h) in block.nodes.items():
            ax, ay = x + dx, y + dy
            if name == START:
                out.append(
                    f'{indent}{START} [shape=point width=0.15 label="" fillcolor=black pos="{ax:.2f},{ay:.2f}"];'
                )
                continue
            state = machine.states[name]
            if state.is_leaf:
                node_attrs = f'pos="{ax:.2f},{ay:.2f}" width={w / 72:.3f} height={h / 72:.3f} id={_quote("state:" + name)}'
                out.append(f"{indent}{_quote(name)} [{node_attrs} tooltip={_quote(state.action or '')}];")
                continue
            inner = laid[name]
            left, bottom = ax - w / 2, ay - h / 2
            out.append(f"{indent}subgraph {_quote('cluster_' + name)} {{")
            out.append(
                f'{indent}  graph [bb="{left:.2f},{bottom:.2f},{left + w:.2f},{bottom + h:.2f}" label={_quote(name)} '
                f'lp="{ax:.2f},{bottom + h - LABEL / 2 - 2:.2f}" style="{_box_style(machine, state)}" color="#888888" '
                f"id={_quote('super:' + name)}];"
            )
            place(name, ax - inner.width / 2, bottom + PAD, indent + "  ")
            out.append(f"{indent}}}")
        placed = set()
        for tail, head, arrow_id, pos, lp in block.edges:
            if not arrow_id:  # a grid link (see grid_links), not drawn
                continue
            placed.add((tail, head))
            pairs = arrows[owner].get((tail, head), [])
            attrs = [f"id={_quote(arrow_id)}", f'pos="{_shift(pos, dx, dy)}"']
            label = _arrow_label(pairs)
            if label:
                attrs.append(f"label={_label(label)}")
                if lp:
                    attrs.append(f'lp="{_shift(lp, dx, dy)}"')
            edge_lines.append(_edge_line(tail, head, pairs, attrs, edges))
        for (tail, head), pairs in blocks[owner].arrows.items():  # a dense block's other arrows
            if (tail, head) not in placed and tail != head:
                attrs = [f"id={_quote(_arrow_id(tail, head, pairs))}", 'color="#00000066"']
                attrs.append(f'pos="{straight(block.nodes[tail], block.nodes[head], dx, dy)}"')
                edge_lines.append(_edge_line(tail, head, pairs, attrs, edges))

    place(ROOT, 0.0, 0.0, "")
    # An arrow's ends are the boxes of superstates: Graphviz knows them as clusters, not nodes, so
    # an invisible point at each box's centre stands in as the end (the arrow is drawn from pos).
    anchors = sorted(
        {end for line_pairs in arrows.values() for pair in line_pairs for end in pair if end in blocks}
    )
    for name in anchors:
        x, y = _centre(laid, machine, name)
        out.append(f'{_quote(name)} [shape=point style=invis width=0.01 label="" pos="{x:.2f},{y:.2f}"];')
    out.extend(edge_lines)
    out.append("}")
    return "\n".join(out) + "\n", edges


def _border(box: tuple[float, float, float, float], toward: tuple[float, float]) -> tuple[float, float]:
    """Where the line from the centre of ``box`` (x, y, width, height) to ``toward`` leaves it."""
    x, y, w, h = box
    dx, dy = toward[0] - x, toward[1] - y
    scale = min(w / 2 / abs(dx) if dx else float("inf"), h / 2 / abs(dy) if dy else float("inf"), 1.0)
    return x + dx * scale, y + dy * scale


def straight(
    tail: tuple[float, float, float, float], head: tuple[float, float, float, float], dx: float, dy: float
) -> str:
    """A straight arrow from box ``tail`` to box ``head`` (both x, y, width, height), border to
    border, as Graphviz's ``pos`` moved by (dx, dy)."""
    start = _border(tail, head[:2])
    tip = _border(head, tail[:2])
    length = max(1e-6, ((tip[0] - start[0]) ** 2 + (tip[1] - start[1]) ** 2) ** 0.5)
    back = min(10.0, length / 2) / length
    end = (tip[0] - (tip[0] - start[0]) * back, tip[1] - (tip[1] - start[1]) * back)
    points = [
        start,
        *((start[0] + (end[0] - start[0]) * k / 3, start[1] + (end[1] - start[1]) * k / 3) for k in (1, 2)),
        end,
    ]
    return f"e,{tip[0] + dx:.2f},{tip[1] + dy:.2f} " + " ".join(
        f"{px + dx:.2f},{py + dy:.2f}" for px, py in points
    )


def _edge_line(
    tail: str,
    head: str,
    pairs: list[tuple[str, str]],
    attrs: list[str],
    edges: dict[str, list[tuple[str, str]]],
) -> str:
    if pairs:
        edges[_arrow_id(tail, head, pairs)] = sorted(pairs)
        attrs.append(f"tooltip={_quote(', '.join(sorted({event for _, event in pairs})))}")
    return f"{_quote(tail)} -> {_quote(head)} [{' '.join(attrs)}];"


def _centre(laid: dict[str, _Laid], machine: MachineSpec, name: str) -> tuple[float, float]:
    """Where a superstate's box centre is, in the whole drawing."""
    x, y = 0.0, 0.0
    chain = _chain(machine, name)
    for inner, outer in zip(reversed(chain[:-1]), reversed(chain[1:]), strict=True):
        block = laid[outer]
        cx, cy, _, h = block.nodes[inner]
        ax, ay = cx + x, cy + y
        if inner == name:
            return ax, ay
        x, y = ax - laid[inner].width / 2, ay - h / 2 + PAD
    return x, y


Runner = Callable[[list[str], bytes, float | None], bytes]


def run_graphviz(
    args: list[str],
    data: bytes,
    timeout: float | None = None,
    *,
    memory: int | None = None,
    started: Callable[[subprocess.Popen[bytes]], None] | None = None,
) -> bytes:
    """Run a Graphviz program (``args[0]``) on ``data``, within ``timeout`` real seconds and
    ``memory`` bytes of address space: past either it is stopped and a :class:`CyborgError` names
    the cap. ``started`` receives the process (so a server can kill it when it stops)."""
    if shutil.which(args[0]) is None:
        raise CyborgError(
            f"Graphviz's {args[0]!r} program is not installed, so the graph cannot be drawn; "
            "fix: install it (apt-get install graphviz) or write a .dot file instead"
        )
    process = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    if memory is not None:  # Graphviz waits for its input, so the cap is in place before it lays anything out
        with contextlib.suppress(ProcessLookupError):
            resource.prlimit(process.pid, resource.RLIMIT_AS, (memory, memory))
    if started is not None:
        started(process)
    try:
        out, err = process.communicate(data, timeout=timeout)
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        raise CyborgError(
            f"Graphviz took longer than {timeout:g} s (the limit) to lay out this machine; "
            "fix: draw it offline with `cyborg graph FILE -o machine.svg`, or group states in superstates"
        ) from None
    if process.returncode != 0:
        problem = err.decode(errors="replace").strip().splitlines()
        if memory is not None and (process.returncode < 0 or any("memory" in line for line in problem)):
            raise CyborgError(
                f"Graphviz needed more than {memory // 2**20} MiB (the limit) to lay out this machine, "
                f"or was stopped (exit {process.returncode}); fix: draw it offline with "
                "`cyborg graph FILE -o machine.svg`"
            )
        raise CyborgError(f"Graphviz ({' '.join(args)}) failed: {' '.join(problem[-3:])}")
    return bytes(out)


def lay_out(machine: MachineSpec, run: Runner | None = None, *, timeout: float | None = None) -> Layout:
    """Lay ``machine`` out: one ``dot`` run per depth of superstates, innermost first, each block
    in both directions (two ``dot`` processes side by side; see :func:`choose`).

    ``run(args, input, timeout)`` runs a Graphviz program (default :func:`run_graphviz`; it is
    called from two threads at once);
    ``timeout`` bounds each run and the layout as a whole (checked between runs).
    """
    runner: Runner = run or (lambda args, data, left: run_graphviz(args, data, left))
    began = time.perf_counter()
    blocks = blocks_of(machine)
    laid: dict[str, _Laid] = {}
    sizes: dict[str, tuple[float, float]] = {}
    runs = 0
    for depth in sorted({block.depth for block in blocks.values()}, reverse=True):
        level = [block for block in blocks.values() if block.depth == depth]
        sources = ["".join(block_source(block, machine, sizes, way) for block in level) for way in DIRECTIONS]
        with ThreadPoolExecutor(len(DIRECTIONS)) as pool:  # one dot per direction, side by side
            outputs = list(
                pool.map(
                    lambda source: runner(["dot", "-Tjson0", *DOT_ARGS], source.encode(), timeout), sources
                )
            )
        runs += 1
        if timeout is not None and time.perf_counter() - began > timeout:
            raise CyborgError(
                f"Graphviz took longer than {timeout:g} s (the limit) to lay out this machine; "
                "fix: draw it offline with `cyborg graph FILE -o machine.svg`, or group states in superstates"
            )
        ways = [list(parse_json_graphs(output.decode())) for output in outputs]
        if any(len(graphs) != len(level) for graphs in ways):
            raise CyborgError(
                f"Graphviz laid out {[len(graphs) for graphs in ways]} of {len(level)} superstates "
                f"(directions {', '.join(DIRECTIONS)}); fix: report this"
            )
        for index, block in enumerate(level):
            laid[block.owner] = choose(block.owner, [_laid(graphs[index]) for graphs in ways])
            if block.owner != ROOT:
                sizes[block.owner] = box_size(laid[block.owner].width, laid[block.owner].height, block.owner)
    source, edges = compose(machine, blocks, laid)
    return Layout(source, edges, time.perf_counter() - began, runs)


def draw(layout: Layout, fmt: str = "svg", run: Runner | None = None, timeout: float | None = None) -> bytes:
    """The laid out machine in ``fmt`` (svg, png, pdf): Graphviz draws it at the fixed positions."""
    runner: Runner = run or (lambda args, data, left: run_graphviz(args, data, left))
    return runner(["neato", "-n2", f"-T{fmt}"], layout.source.encode(), timeout)
