"""What a module's or gatekeeper's node needs of the configuration, read without the validating models.

``cyborg launch`` validates the whole file once (:mod:`cyborg.app.config`: pydantic models of the
machine, the emotion system, the motivator) and hands each node the digest of the text it
validated (``cyborg node --checked DIGEST``). A module's or gatekeeper's node whose file still has
that digest reads it into a :class:`ConfigSketch`: the ``modules:`` blocks as written, the
gatekeepers and the recording switch as plain data. Its module's own settings are still validated
by its kind (:mod:`cyborg.app.registry`). So a thin node loads neither the configuration models nor
the controller's code (docs/ros1.md, "What a node loads").

:class:`PartConfig` is what :mod:`cyborg.app.parts` and :mod:`cyborg.app.context` read of a
configuration: a :class:`~cyborg.app.config.LoadedConfig` and a :class:`ConfigSketch` both are one.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from cyborg.configfile import key_lines, load_yaml, read_text_file

__all__ = ["ConfigSketch", "GateSketch", "PartConfig", "PartModel", "read_sketch", "text_digest"]


class GateLike(Protocol):
    """A gatekeeper of the configuration (its ``gatekeepers:`` list)."""

    @property
    def name(self) -> str: ...
    @property
    def input(self) -> str: ...
    @property
    def output(self) -> str: ...
    @property
    def resource(self) -> str: ...


class RecordingLike(Protocol):
    @property
    def enabled(self) -> bool: ...


class PartModel(Protocol):
    """The sections of the configuration a part's node reads."""

    @property
    def modules(self) -> Mapping[str, Any]: ...
    @property
    def gatekeepers(self) -> Sequence[GateLike]: ...
    @property
    def recording(self) -> RecordingLike: ...


class PartConfig(Protocol):
    """What building a module's or gatekeeper's part reads of a configuration."""

    @property
    def source(self) -> str: ...
    @property
    def text(self) -> str: ...
    @property
    def model(self) -> PartModel: ...
    def where(self, *path: str) -> str: ...


@dataclass(frozen=True)
class GateSketch:
    name: str
    input: str
    output: str
    resource: str


@dataclass(frozen=True)
class RecordingSketch:
    enabled: bool = True


@dataclass(frozen=True)
class ModelSketch:
    modules: dict[str, Any] = field(default_factory=dict)
    gatekeepers: list[GateSketch] = field(default_factory=list)
    recording: RecordingSketch = field(default_factory=RecordingSketch)


@dataclass(frozen=True)
class ConfigSketch:
    """A configuration already validated elsewhere (by the launch), as plain data."""

    source: str
    model: ModelSketch
    text: str = field(default="", repr=False)

    def where(self, *path: str) -> str:
        """``"line N: "`` for the key at ``path``, or "" if unknown (as :class:`LoadedConfig`'s)."""
        line = key_lines(self.text).get(path) if self.text else None
        return f"line {line}: " if line is not None else ""

    def has_part(self, name: str) -> bool:
        """Whether ``name`` is a module or a gatekeeper here: a part a sketch can build."""
        return name in self.model.modules or any(gate.name == name for gate in self.model.gatekeepers)


def text_digest(text: str) -> str:
    """The digest ``cyborg launch`` hands its nodes: of the configuration's text it validated."""
    return hashlib.sha256(text.encode("utf-8", errors="surrogateescape")).hexdigest()


def read_sketch(path: Path, digest: str) -> ConfigSketch | None:
    """The sketch of the file at ``path`` when its text still has ``digest``; None when it changed
    since it was validated (or cannot be read): the caller then validates it whole."""
    try:
        text = read_text_file(path)
    except OSError:
        return None
    if text_digest(text) != digest:
        return None
    data = load_yaml(text, str(path))
    if not isinstance(data, dict):
        return None
    gates = [
        GateSketch(str(g["name"]), str(g["input"]), str(g["output"]), str(g["resource"]))
        for g in data.get("gatekeepers") or []
    ]
    recording = data.get("recording") or {}
    model = ModelSketch(
        modules=dict(data.get("modules") or {}),
        gatekeepers=gates,
        recording=RecordingSketch(enabled=bool(recording.get("enabled", True))),
    )
    return ConfigSketch(source=str(path), model=model, text=text)
