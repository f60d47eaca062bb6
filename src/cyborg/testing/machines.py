"""Generated state machines of any size, for benchmarks and tests of the graph and dashboard.

Two shapes, both valid configurations (every leaf has an action and an ``aborted`` way out):

- :func:`structured`: the way students grow the Cyborg: a hub state ``idle`` and superstates of
  5-20 states (one per module or activity); past 20 superstates they are grouped in areas of
  5-20 superstates. Leaves lead to their siblings (``next``, ``back``, ``skip``), superstates to
  ``idle`` and to a few other superstates.
- :func:`random_machine`: superstates of random size (0-40, some leaves at the top level) and
  every leaf with 2-4 events to states anywhere: the worst case for a layout.

Each returns the YAML's mapping (``initial``, ``states`` and a ``modules`` section of one
placeholder module serving every leaf), so ``cyborg sim --config`` can run it;
:func:`machine_spec` turns it into a :class:`MachineSpec`. Deterministic for a given seed.
"""

from __future__ import annotations

import random
from typing import Any

from cyborg.controller.config import MachineModel, build_machine
from cyborg.controller.machine import MachineSpec
from cyborg.errors import InvalidValueError

__all__ = ["MODULE", "machine_spec", "random_machine", "structured"]

MODULE = "generated"  # the placeholder module that serves every leaf of a generated machine

State = dict[str, Any]


def _check(states: int) -> None:
    if states < 2:
        raise InvalidValueError(
            f"a generated machine needs at least 2 states, got {states}; fix: ask for 2 or more"
        )


def _leaf(name: str, transitions: dict[str, str]) -> State:
    return {"action": f"{MODULE}/{name}", "transitions": transitions}


def _sizes(total: int, low: int, high: int, rng: random.Random) -> list[int]:
    """``total`` split into parts of ``low``..``high`` (the last part may be smaller if it must)."""
    sizes: list[int] = []
    while total > 0:
        size = min(total, rng.randint(low, high))
        if 0 < total - size < low:  # no runt at the end: fold it into this part
            size = total
        sizes.append(size)
        total -= size
    return sizes


def structured(states: int, seed: int = 0) -> dict[str, Any]:
    """A machine of ``states`` leaf states shaped the way students write them (see the module)."""
    _check(states)
    rng = random.Random(seed)
    sizes = _sizes(states - 1, 5, 20, rng) if states > 6 else [states - 1]
    groups: list[tuple[str, State]] = []
    for g, size in enumerate(sizes):
        names = [f"g{g}_s{i}" for i in range(size)]
        children: State = {}
        for i, name in enumerate(names):
            transitions = {"next": names[(i + 1) % size], "succeeded": names[(i + 1) % size]}
            if i > 0:
                transitions["back"] = names[i - 1]
            if size > 3 and rng.random() < 0.5:
                transitions["skip"] = names[rng.randrange(size)]
            children[name] = _leaf(name, transitions)
        groups.append((f"group{g}", {"states": children, "transitions": {"aborted": "idle", "done": "idle"}}))
    for g, (_, group) in enumerate(groups):  # a few ways from one activity to another
        for _ in range(rng.randint(1, 2)):
            other = rng.randrange(len(groups))
            if other != g:
                group["transitions"][f"to_group{other}"] = groups[other][0]
    top: list[tuple[str, State]] = groups
    if len(groups) > 20:  # areas of 5-20 superstates
        top, start = [], 0
        for a, size in enumerate(_sizes(len(groups), 5, 20, rng)):
            members = dict(groups[start : start + size])
            start += size
            top.append((f"area{a}", {"states": members, "transitions": {"aborted": "idle"}}))
    idle = _leaf("idle", {"aborted": "idle"})
    for name, _ in top:
        idle["transitions"][f"start_{name}"] = name
    machine: State = {"idle": idle, **dict(top)}
    return _config(machine)


def random_machine(states: int, seed: int = 0) -> dict[str, Any]:
    """A machine of ``states`` leaf states with random superstates and random transitions."""
    _check(states)
    rng = random.Random(seed)
    leaves = [f"s{i}" for i in range(states)]
    events = [f"e{k}" for k in range(max(4, states // 10))]
    supers: list[str] = []
    machine: State = {}
    index = 0
    while index < states:
        size = min(states - index, rng.randint(0, 40))
        if size <= 1 or index == 0:  # a leaf at the top level (the first one is the initial state)
            machine[leaves[index]] = None
            index += 1
            continue
        name = f"super{len(supers)}"
        supers.append(name)
        machine[name] = {"states": dict.fromkeys(leaves[index : index + size]), "transitions": {}}
        index += size
    targets = leaves + supers

    def fill(scope: State) -> None:
        for name, value in scope.items():
            if value is None:
                transitions = {rng.choice(events): rng.choice(targets) for _ in range(rng.randint(2, 4))}
                transitions["aborted"] = leaves[0]
                scope[name] = _leaf(name, transitions)
            else:
                value["transitions"] = {
                    rng.choice(events): rng.choice(targets) for _ in range(rng.randint(0, 2))
                }
                fill(value["states"])

    fill(machine)
    return _config(machine)


def _config(machine: State) -> dict[str, Any]:
    servers: list[dict[str, Any]] = []

    def collect(scope: State) -> None:
        for value in scope.values():
            if "action" in value:
                servers.append({"action": value["action"], "duration": 5.0})
            else:
                collect(value["states"])

    collect(machine)
    first = next(iter(machine))
    return {
        "initial": first,
        "states": machine,
        "modules": {MODULE: {"kind": "placeholder", "servers": servers}},
    }


def machine_spec(config: dict[str, Any]) -> MachineSpec:
    """The :class:`MachineSpec` of a generated configuration."""
    model = MachineModel.model_validate({k: v for k, v in config.items() if k in ("initial", "states")})
    return build_machine(model, "<generated>")[0]
