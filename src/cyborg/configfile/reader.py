"""Reading configuration files: UTF-8 text within a size limit, and YAML parsed safely.

Every configuration-like file of the robot (the robot's YAML, scenario scripts, ROS map
files) is read here, so each gets the same protection and the same kind of messages:
the size, depth and alias-expansion limits of :mod:`cyborg.limits`, duplicate keys
reported with their line (PyYAML silently keeps the last one), and syntax errors with
the line, column and the usual fix. Problems are :class:`~cyborg.errors.ConfigError`.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from cyborg.configfile.errors import Location, name_location, yaml_kind
from cyborg.errors import ConfigError
from cyborg.limits import MAX_YAML_BYTES, MAX_YAML_DEPTH, MAX_YAML_NODES


def _generic_duplicate(path: Location, key: str) -> tuple[str, str]:
    return f"duplicate key {key!r}", "keep one of the two entries (merge them if both are mappings)"


@dataclass(frozen=True)
class KeyRules:
    """What a file's mapping keys mean, for the messages about duplicate and non-text keys.

    ``name`` names the mapping at a path (keys and list indexes from the top);
    ``duplicate(path, key)`` gives (what is wrong, fix) for a key written twice there;
    ``names(path)`` is true where the keys are names, so a key YAML reads as a number or
    boolean (``on:``, ``1:``) is refused with the advice to quote it.
    """

    name: Callable[[Location], str] = name_location
    duplicate: Callable[[Location, str], tuple[str, str]] = _generic_duplicate
    names: Callable[[Location], bool] = lambda path: False


PLAIN_KEYS = KeyRules()
"""The rules for a file with no named mappings: duplicates are reported plainly."""


def read_text_file(path: Path) -> str:
    """The UTF-8 text of a YAML file; ConfigError if it is too large or not UTF-8 (OSError passes)."""
    with path.open("rb") as handle:
        data = handle.read(MAX_YAML_BYTES + 1)
    if len(data) > MAX_YAML_BYTES:
        raise ConfigError(
            f"the file is over the limit of {MAX_YAML_BYTES:,} bytes; fix: check that this is the right file, "
            "and split a long scenario into several scripts",
            source=str(path),
        )
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise ConfigError(
            f"line {line}: the file is not UTF-8 text (byte {data[exc.start]:#04x} at offset {exc.start}); "
            "fix: save it as UTF-8 in your editor (e.g. `iconv -f latin1 -t utf-8`)",
            source=str(path),
        ) from None


def read_yaml_file(path: Path, keys: KeyRules = PLAIN_KEYS) -> Any:
    """:func:`read_text_file` then :func:`load_yaml`; ConfigError names the path (also if unreadable)."""
    try:
        text = read_text_file(path)
    except OSError as exc:
        raise ConfigError(
            f"cannot read the file: {exc.strerror}; fix: check the path", source=str(path)
        ) from exc
    return load_yaml(text, str(path), keys)


def item_lines(text: str, key: str) -> list[int]:
    """Line numbers (1-based) of each entry of the top-level list ``key``; [] if there is none.

    For messages about list entries (a scenario's ``steps``); call it on text :func:`load_yaml` accepted.
    """
    try:
        root = yaml.compose(text, Loader=yaml_loader(text))
    except (yaml.YAMLError, RecursionError):
        return []
    if not isinstance(root, yaml.MappingNode):
        return []
    for name, value in root.value:
        if name.value == key and isinstance(value, yaml.SequenceNode):
            return [item.start_mark.line + 1 for item in value.value]
    return []


def key_lines(text: str) -> dict[tuple[str, ...], int]:
    """The line (1-based) of every mapping key, by its path from the top, e.g.
    ``("states", "idle", "transitions")``; {} when the text is no YAML.

    For messages about a valid file's parts (``cyborg validate``'s warnings); call it on text
    :func:`load_yaml` accepted.
    """
    try:
        root = yaml.compose(text, Loader=yaml_loader(text))
    except (yaml.YAMLError, RecursionError):
        return {}
    lines: dict[tuple[str, ...], int] = {}
    pending: list[tuple[tuple[str, ...], yaml.Node]] = [((), root)] if root is not None else []
    while pending:
        path, node = pending.pop()
        if isinstance(node, yaml.MappingNode):
            for key, value in node.value:
                if isinstance(key, yaml.ScalarNode):
                    here = (*path, str(key.value))
                    lines.setdefault(here, key.start_mark.line + 1)
                    pending.append((here, value))
    return lines


class _ValueNotBuilt(Exception):
    """A scalar YAML reads as a date or a number that Python cannot build (``2026-13-01``, 5,000 digits).

    Internal, not a CyborgError: it never leaves this module (the loader turns it into a ConfigError
    with the file's name), and it must not be caught as a yaml.YAMLError on the way.
    """


def _checked(
    build: Callable[[Any, yaml.ScalarNode], Any], what: str, fix: str
) -> Callable[[Any, yaml.ScalarNode], Any]:
    def construct(loader: Any, node: yaml.ScalarNode) -> Any:
        try:
            return build(loader, node)
        except (ValueError, OverflowError) as exc:
            long = len(node.value) > 40
            shown = f"{node.value[:20]}... ({len(node.value):,} characters)" if long else node.value
            reason = "over Python's limit of 4,300 digits" if "digits" in str(exc) else str(exc)
            raise _ValueNotBuilt(
                f"line {node.start_mark.line + 1}: {shown} is not a usable {what} ({reason}); fix: {fix}"
            ) from None

    return construct


_TIMESTAMP = "tag:yaml.org,2002:timestamp"
_INT = "tag:yaml.org,2002:int"
_DATE_FIX = "correct the date (YYYY-MM-DD, a real day), or put the value in quotes if it is text"
_INT_FIX = "give a number of at most 4,300 digits, or put the value in quotes if it is text"


class _SafeLoader(yaml.SafeLoader):
    """PyYAML's safe loader, with a ConfigError line instead of a ValueError for dates and numbers."""


class _CSafeLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """The same on libyaml."""


for _loader in (_SafeLoader, _CSafeLoader):
    _loader.add_constructor(_TIMESTAMP, _checked(yaml.SafeLoader.construct_yaml_timestamp, "date", _DATE_FIX))
    _loader.add_constructor(_INT, _checked(yaml.SafeLoader.construct_yaml_int, "whole number", _INT_FIX))

Loader = yaml.SafeLoader | yaml.CSafeLoader


def load_yaml(text: str, source: str, keys: KeyRules = PLAIN_KEYS) -> Any:
    """Parse YAML, reporting syntax errors and duplicate keys with line numbers.

    PyYAML silently keeps the last of two equal keys; here every duplicate is an error
    whose advice ``keys`` fits to where it is (the robot's YAML: two states of one name,
    one event twice in a state's transitions...). Mappings, lists and aliases are bounded
    by :data:`~cyborg.limits.MAX_YAML_BYTES`, ``MAX_YAML_DEPTH`` and ``MAX_YAML_NODES``.
    """
    size = len(text.encode("utf-8", errors="surrogateescape"))
    if size > MAX_YAML_BYTES:
        raise ConfigError(
            f"the file is {size:,} bytes, over the limit of {MAX_YAML_BYTES:,} bytes; fix: check that this is the "
            "right file, and split a long scenario into several scripts",
            source=source,
        )
    if yaml_loader(text) is yaml.CSafeLoader:
        try:
            return _load_yaml_with(_CSafeLoader(text), source, keys)
        except ConfigError as exc:
            if not isinstance(exc.__cause__, yaml.YAMLError):
                raise
            # The C loader's messages have no file name and no excerpt: the Python one tells it better.
    loader = _SafeLoader(text)
    loader.name = source  # syntax errors then say 'in "machine.yaml", line 3'
    return _load_yaml_with(loader, source, keys)


_FLOW_BRACKETS = re.compile(r"[\[\]{}]")
_C_LOADER_DEPTH = 1000
"""libyaml's composer recurses in C: tens of thousands of nested brackets crash the process."""


def yaml_loader(text: str) -> type[Loader]:
    """The fast C loader (libyaml) if it is there and safe for ``text``, else the Python one.

    Brackets inside quotes count too: a file that merely looks deep is read by the Python
    loader, which refuses real depth with a RecursionError instead of crashing.
    """
    if not hasattr(yaml, "CSafeLoader"):
        return yaml.SafeLoader
    depth = 0
    for match in _FLOW_BRACKETS.finditer(text):
        depth += 1 if match.group() in "[{" else -1
        if depth > _C_LOADER_DEPTH:
            return yaml.SafeLoader
    return yaml.CSafeLoader


def _load_yaml_with(loader: Loader, source: str, keys: KeyRules) -> Any:
    try:
        try:
            root = loader.get_single_node()
        except RecursionError:
            raise ConfigError(
                f"the values are nested too deeply (over {MAX_YAML_DEPTH} levels of mappings and lists); "
                "fix: flatten the structure",
                source=source,
            ) from None
        if root is None:
            return None
        _check_shape(root, source)
        duplicates: list[str] = []
        _find_duplicates(loader, root, [], duplicates, set(), keys)
        if duplicates:
            raise ConfigError(duplicates, source=source)
        return loader.construct_document(root)
    except _ValueNotBuilt as exc:
        raise ConfigError(str(exc), source=source) from None
    except yaml.YAMLError as exc:
        raise ConfigError(
            f"not valid YAML: {exc}\nfix: correct the syntax at the line and column shown "
            "(usually the indentation, a missing ':' or space after it, or an unclosed bracket or quote)",
            source=source,
        ) from exc
    finally:
        loader.dispose()  # type: ignore[no-untyped-call]


_MERGE_TAG = "tag:yaml.org,2002:merge"


def _check_shape(root: yaml.Node, source: str) -> None:
    """Refuse a document that expands to too many values, nests too deeply or refers to itself.

    Aliases (``*name``) repeat a node without copying it, so a few hundred bytes can stand for
    billions of values ("billion laughs"); the expanded count is summed over the node graph
    (each node once) before anything is constructed.
    """
    expanded: dict[int, int] = {}
    on_path: set[int] = set()
    stack: list[tuple[yaml.Node, int, bool]] = [(root, 1, False)]
    while stack:
        node, depth, done = stack.pop()
        key = id(node)
        if done:
            on_path.discard(key)
            total = 1 + sum(expanded[id(child)] for child in _children(node))
            if total > MAX_YAML_NODES:
                raise ConfigError(
                    f"line {node.start_mark.line + 1}: the YAML expands to over {MAX_YAML_NODES:,} values "
                    "(aliases '*name' repeat what they name); fix: write the values out or use fewer "
                    "aliases",
                    source=source,
                )
            expanded[key] = total
            continue
        if key in expanded:
            continue
        if key in on_path:
            raise ConfigError(
                f"line {node.start_mark.line + 1}: an alias refers to the mapping or list that contains it, "
                "which never ends; fix: remove that alias",
                source=source,
            )
        if depth > MAX_YAML_DEPTH:
            raise ConfigError(
                f"line {node.start_mark.line + 1}: the values are nested over {MAX_YAML_DEPTH} levels deep; "
                "fix: flatten the structure",
                source=source,
            )
        on_path.add(key)
        stack.append((node, depth, True))
        stack.extend((child, depth + 1, False) for child in _children(node) if id(child) not in expanded)


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [part for pair in node.value for part in pair]
    return []


def _find_duplicates(
    loader: Loader, node: yaml.Node, path: list[Any], out: list[str], seen_nodes: set[int], keys: KeyRules
) -> None:
    if id(node) in seen_nodes:  # an alias of a node already checked
        return
    seen_nodes.add(id(node))
    if isinstance(node, yaml.SequenceNode):
        for index, item in enumerate(node.value):
            _find_duplicates(loader, item, [*path, index], out, seen_nodes, keys)
        return
    if not isinstance(node, yaml.MappingNode):
        return
    first_line: dict[Any, int] = {}
    for key_node, value_node in node.value:
        key: Any = key_node.value
        if isinstance(key_node, yaml.ScalarNode) and key_node.tag != _MERGE_TAG:
            key = loader.construct_object(key_node)  # type: ignore[no-untyped-call]
            line = key_node.start_mark.line + 1
            try:
                first = first_line.get(key)
            except TypeError:  # an unhashable key: pydantic reports it later
                first = None
            if not isinstance(key, str) and keys.names(path):
                out.append(
                    f"line {line}: {keys.name(path)}: YAML reads the key {key_node.value!r} as "
                    f"{yaml_kind(key)}, not as a name; fix: put it in quotes, e.g. '{key_node.value}':"
                )
            if first is not None:
                what, fix = keys.duplicate(path, str(key_node.value))
                earlier = "earlier on the same line" if first == line else f"first at line {first}"
                out.append(f"line {line}: {keys.name(path)}: {what} ({earlier}); fix: {fix}")
            else:
                with contextlib.suppress(TypeError):
                    first_line[key] = line
        _find_duplicates(loader, value_node, [*path, key], out, seen_nodes, keys)
