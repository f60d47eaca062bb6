"""The pydantic side of a kind's settings: :class:`ModuleSettings` and the model of any settings class.

Imported where a configuration is validated (``cyborg launch``, ``cyborg check``, the embedded
robot, a node started by hand) and by a plug-in whose settings are a :class:`ModuleSettings`; a
thin node the launch checked its file for builds its dataclass settings without it
(:func:`cyborg.modules.kind.checked_settings`).
"""

from __future__ import annotations

import dataclasses
from types import UnionType
from typing import Any, Union, get_args, get_origin, get_type_hints

from pydantic import BaseModel, ConfigDict, Field, create_model

from cyborg.errors import ConfigError
from cyborg.modules.plain_settings import KindSettings

__all__ = ["ModuleSettings", "settings_model"]


class ModuleSettings(BaseModel, KindSettings):
    """Base of a kind's settings: the keys of its YAML block besides ``kind:``.

    Unknown keys are refused, and each field's ``description`` and default go into the
    ``modules:`` table of ``docs/configuration.md``.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)


_MODELS: dict[type[Any], type[BaseModel]] = {}


def settings_model(settings: type[Any]) -> type[BaseModel]:
    """The pydantic model that validates ``settings``: itself when it is one; for a dataclass of
    :class:`~cyborg.modules.kind.KindSettings` a :class:`ModuleSettings` of the same fields
    (``Field(**metadata)`` each, nested dataclasses as their models), name and docstring."""
    if isinstance(settings, type) and issubclass(settings, BaseModel):
        return settings
    made = _MODELS.get(settings)
    if made is None:
        made = _MODELS[settings] = _model_of(settings)
    return made


def _model_of(settings: type[Any]) -> type[BaseModel]:
    if not (isinstance(settings, type) and dataclasses.is_dataclass(settings)):
        raise ConfigError(
            f"module kind settings {settings!r} are neither a pydantic model nor a dataclass; fix: "
            "derive them from cyborg.modules.ModuleSettings"
        )
    hints = get_type_hints(settings)
    fields: dict[str, Any] = {}
    for field in dataclasses.fields(settings):
        extra: dict[str, Any] = dict(field.metadata)
        if field.default is not dataclasses.MISSING:
            extra["default"] = field.default
        elif field.default_factory is not dataclasses.MISSING:
            extra["default_factory"] = field.default_factory
        fields[field.name] = (_modelled(hints[field.name]), Field(**extra))
    model: type[BaseModel] = create_model(  # type: ignore[call-overload]
        settings.__name__,
        __base__=ModuleSettings,
        __doc__=settings.__doc__,
        __module__=settings.__module__,
        **fields,
    )
    return model


def _modelled(annotation: Any) -> Any:
    """``annotation`` with each dataclass of settings in it replaced by its model."""
    if isinstance(annotation, type) and dataclasses.is_dataclass(annotation):
        return settings_model(annotation)
    origin, args = get_origin(annotation), get_args(annotation)
    if origin is None or not args:
        return annotation
    members = tuple(_modelled(arg) for arg in args)
    if members == args:
        return annotation
    if origin in (Union, UnionType):
        return Union[members]  # noqa: UP007 (built from a tuple)
    return origin[members if len(members) > 1 else members[0]]
