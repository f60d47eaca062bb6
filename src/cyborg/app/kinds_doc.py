"""The reference of the installed module kinds, written from their settings models.

``cyborg kinds`` prints it; ``docs/configuration.md`` holds the built-in kinds' part, and a
test keeps that part equal to what this module writes, so the doc cannot drift from the code.
"""

from __future__ import annotations

from typing import Any, get_args, get_origin

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

from cyborg.app.registry import KindRegistry
from cyborg.errors import ConfigError
from cyborg.modules.settings import settings_model

__all__ = ["kinds_markdown", "settings_rows"]


def _default(value: Any) -> str:
    if value is PydanticUndefined:
        return "required"
    if value is None:
        return "none"
    if value == "":
        return '`""`'
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, tuple | list):
        return f"`[{', '.join(str(v) for v in value)}]`"
    return f"`{value}`"


def _nested_model(annotation: Any) -> type[BaseModel] | None:
    """The model inside ``list[Model]`` (or ``Model``), if the field holds models."""
    candidates = [annotation, *get_args(annotation)]
    if get_origin(annotation) is not None:
        candidates += [a for arg in get_args(annotation) for a in get_args(arg)]
    for candidate in candidates:
        if isinstance(candidate, type) and issubclass(candidate, BaseModel):
            return candidate
    return None


def settings_rows(settings: type[Any], prefix: str = "") -> list[tuple[str, str, str]]:
    """(key, default, meaning) of every setting of ``settings`` (a model, or dataclass settings);
    nested models as ``key[].sub``."""
    model = settings_model(settings)
    rows: list[tuple[str, str, str]] = []
    for name, field in model.model_fields.items():
        key = f"{prefix}{name}"
        nested = _nested_model(field.annotation)
        rows.append((key, _default(field.get_default(call_default_factory=True)), field.description or ""))
        if nested is not None:
            rows += settings_rows(nested, prefix=f"{key}[].")
    return rows


def kinds_markdown(registry: KindRegistry, names: list[str] | None = None) -> str:
    """One section per kind: its summary, where it comes from, and the table of its settings."""
    parts: list[str] = []
    for name in names if names is not None else registry.names():
        try:
            kind = registry.get(name)
        except ConfigError as exc:  # that kind only; the others are written all the same
            parts.append(f"### `{name}`\n\nNot usable: {' '.join(exc.problems)}")
            continue
        lines = [f"### `{name}`", "", kind.summary, "", "| key | default | meaning |", "| --- | --- | --- |"]
        lines += [
            f"| `{key}` | {default} | {meaning} |"
            for key, default, meaning in settings_rows(settings_model(kind.settings))
        ]
        parts.append("\n".join(lines))
    return "\n\n".join(parts) + "\n"
