"""The module kinds this installation knows: every ``cyborg.module_kinds`` entry point.

Built-in kinds and a student's pip-installed package register the same way, so
``cyborg validate``, ``cyborg sim``, ``cyborg node``, ``cyborg launch`` and scenario
runs all know the same kinds. A kind's code is imported only when a configuration
uses it, so a node of one placeholder module loads the placeholder and nothing else.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib
import logging
import re
import site
import sys
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cyborg.app.plugin_path import main_path, main_python
from cyborg.errors import ConfigError, CyborgError
from cyborg.modules.kind import BuildContext, Component, KindSettings, ModuleKind, checked_settings
from cyborg.transport.base import Node

if (
    TYPE_CHECKING
):  # importlib.metadata (email, zipfile, csv...: ~2 MiB) is read when a registry reads entry points
    from importlib.metadata import Distribution, EntryPoint

log = logging.getLogger(__name__)

__all__ = [
    "BUILT_IN_KINDS",
    "ENTRY_POINT_GROUP",
    "KindRegistry",
    "build_module",
    "built_in_kinds",
    "module_kinds",
]

ENTRY_POINT_GROUP = "cyborg.module_kinds"
BUILT_IN_KINDS = {
    "conversation": "cyborg.modules.conversation:CONVERSATION_KIND",
    "event_script": "cyborg.modules.event_script:KIND",
    "idle": "cyborg.modules.idle:KIND",
    "music": "cyborg.modules.music:KIND",
    "navigation": "cyborg.navigation.kind:KIND",
    "placeholder": "cyborg.modules.placeholder:KIND",
    "question": "cyborg.modules.conversation:QUESTION_KIND",
    "simulated_base": "cyborg.sim.base:KIND",
    "speech_input": "cyborg.hearing.module:KIND",
    "tts": "cyborg.modules.speech:KIND",
}
"""cyborg's own kinds, as its entry points name them (pyproject.toml; a test keeps the two equal)."""


def _origin(entry: EntryPoint) -> str:
    dist = entry.dist
    package = f"{dist.name} {dist.version}" if dist is not None else "an unknown package"
    return f"{package} ({entry.value})"


_WARNED: set[tuple[str, ...]] = set()
"""Clashes already warned about in this process (a command may read the entry points more than once)."""


def _first_time(clash: tuple[str, ...]) -> bool:
    if clash in _WARNED:
        return False
    _WARNED.add(clash)
    return True


def _builtin(entry: EntryPoint) -> bool:
    """Whether ``entry`` is one of cyborg's own kinds."""
    return entry.dist is not None and _normalized(entry.dist.name) == "cyborg"


def _normalized(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def main_venv_entries() -> list[tuple[EntryPoint, Distribution]]:
    """The kinds of module packages installed in the main venv only, when this Python is another
    one (the ROS 2 venv; :func:`cyborg.app.plugin_path.main_path`): one install serves both."""
    paths = main_path()
    if not paths:
        return []
    from importlib.metadata import distributions

    here = {_normalized(dist.metadata["Name"] or "") for dist in distributions()}
    found: list[tuple[EntryPoint, Distribution]] = []
    for dist in distributions(path=paths):
        name = _normalized(dist.metadata["Name"] or "")
        if name in here:
            continue  # installed here too (cyborg itself; a package installed in both): this one's wins
        here.add(name)
        found.extend((entry, dist) for entry in dist.entry_points if entry.group == ENTRY_POINT_GROUP)
    return found


def _make_importable(dist: Distribution) -> None:
    """Put a main-venv distribution's code on this Python's path, after its own packages: the
    folder it is installed in, and the paths and import hooks of its ``.pth`` files (``pip
    install -e``)."""
    folder = str(Path(str(dist.locate_file(""))))
    if folder not in sys.path:
        sys.path.append(folder)
    for file in dist.files or []:
        if file.suffix == ".pth" and len(file.parts) == 1:
            site.addpackage(folder, file.name, None)


class KindRegistry:
    """Module kinds by name: entry points, loaded on first use, plus kinds given in code.

    ``extra`` kinds (tests, embedding applications) win over entry points of the same name.
    """

    def __init__(
        self,
        entries: Iterable[EntryPoint] | None = None,
        *,
        extra: Mapping[str, ModuleKind[Any]] | None = None,
    ) -> None:
        self._entries: dict[str, EntryPoint] = {}
        self._clashes: dict[str, list[str]] = {}
        self._elsewhere: dict[str, Distribution] = {}
        if entries is None:
            from importlib.metadata import entry_points

            shared = main_venv_entries()
            entries = [*entry_points(group=ENTRY_POINT_GROUP), *(entry for entry, _ in shared)]
            self._elsewhere = {entry.value: dist for entry, dist in shared}
        self.ignored: dict[str, list[str]] = {}
        """Kinds of other packages named like a built-in kind: the built-in is used (name -> origins)."""
        for entry in entries:
            known = self._entries.get(entry.name)
            if known is None:
                self._entries[entry.name] = entry
            elif known.value == entry.value:
                continue
            elif _builtin(known) or _builtin(entry):
                builtin, other = (known, entry) if _builtin(known) else (entry, known)
                self._entries[entry.name] = builtin
                self.ignored.setdefault(entry.name, []).append(_origin(other))
            else:
                self._clashes.setdefault(entry.name, [_origin(known)]).append(_origin(entry))
        for name, others in self.ignored.items():
            if not _first_time(("ignored", name, *others)):
                continue
            log.warning(
                "module kind %r of %s is ignored: cyborg has a built-in kind of that name, which is used; "
                "fix: rename the kind in that package's entry points (and its modules: blocks), then "
                "reinstall it",
                name,
                " and ".join(others),
            )
        for name, origins in self._clashes.items():
            if not _first_time(("clash", name, *origins)):
                continue
            log.warning(
                "module kind %r is offered by several packages (%s): it cannot be used until one goes, the "
                "other kinds can; fix: uninstall one of them, or rename the kind in one package's entry points",
                name,
                "; ".join(origins),
            )
        self._loaded: dict[str, ModuleKind[Any]] = dict(extra or {})

    def clashes(self) -> dict[str, list[str]]:
        """Kinds offered by several packages other than cyborg (name -> origins): unusable until one goes."""
        return {name: list(origins) for name, origins in self._clashes.items()}

    def names(self) -> list[str]:
        """Every kind's name, sorted (nothing is imported to list them)."""
        return sorted({*self._entries, *self._loaded})

    def origin(self, name: str) -> str:
        """Where kind ``name`` comes from: package, version and object, for messages and docs."""
        if name in self._loaded and name not in self._entries:
            return "given in code"
        return _origin(self._entries[name])

    def get(self, name: str, *, source: str | None = None) -> ModuleKind[Any]:
        """The kind called ``name``, imported now if it was not yet.

        Raises :class:`ConfigError` naming the fix when no package offers it, when two offer
        it, or when its package fails to import or offers something that is no ModuleKind.
        """
        kind = self._loaded.get(name)
        if kind is not None:
            return kind
        if name in self._clashes:
            raise ConfigError(
                f"module kind {name!r} is offered by several packages: {'; '.join(self._clashes[name])}; "
                "fix: uninstall one of them, or rename the kind in one package's entry points",
                source=source,
            )
        entry = self._entries.get(name)
        if entry is None:
            close = difflib.get_close_matches(name, self.names(), n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ConfigError(
                f"unknown kind {name!r}; fix: {hint}use one of {', '.join(self.names())}, or install "
                f"the package that offers it with `{main_python()} -m pip install -e PACKAGE_FOLDER` "
                f"(one install serves every transport, --ros2 too; the package registers the kind in "
                f"the entry-point group {ENTRY_POINT_GROUP!r})",
                source=source,
            )
        try:
            dist = self._elsewhere.get(entry.value)
            if dist is not None:
                _make_importable(dist)
            loaded = entry.load()
        except (Exception, SystemExit) as exc:  # SystemExit: a module that calls sys.exit() when imported
            reason = (
                f"it called sys.exit({exc.code!r}) while being imported"
                if isinstance(exc, SystemExit)
                else repr(exc)
            )
            raise ConfigError(
                f"module kind {name!r} from {_origin(entry)} could not be imported: {reason}; "
                "fix: repair or reinstall that package",
                source=source,
            ) from None
        if not isinstance(loaded, ModuleKind):
            raise ConfigError(
                f"module kind {name!r} from {_origin(entry)} is a {type(loaded).__name__}, not a ModuleKind; "
                "fix: point the entry point at a cyborg.modules.ModuleKind(settings, build)",
                source=source,
            )
        self._loaded[name] = loaded
        return loaded

    def parse(
        self, node_name: str, raw: Any, *, source: str | None = None
    ) -> tuple[ModuleKind[Any], KindSettings]:
        """Validate one ``modules:`` block; errors name the module, the setting and the fix."""
        from pydantic import BaseModel, ValidationError

        from cyborg.configfile import describe_errors
        from cyborg.modules.settings import settings_model

        kind, settings = self._kind_of(node_name, raw, source)
        model = settings_model(kind.settings)
        try:
            validated = model.model_validate(settings)
        except ValidationError as exc:
            problems = describe_errors(exc, model, where=f"module {node_name!r}", doc="docs/configuration.md")
            raise ConfigError(problems, source=source) from exc
        if isinstance(validated, kind.settings):
            return kind, validated
        assert isinstance(validated, BaseModel)  # the model of dataclass settings: made into them
        return kind, checked_settings(kind.settings, validated.model_dump())

    def parse_checked(
        self, node_name: str, raw: Any, *, source: str | None = None
    ) -> tuple[ModuleKind[Any], KindSettings]:
        """:meth:`parse` for a block validated already (by ``cyborg launch``): dataclass settings
        are made without pydantic (:func:`~cyborg.modules.kind.checked_settings`); a pydantic
        model is validated as in :meth:`parse`."""
        kind, settings = self._kind_of(node_name, raw, source)
        cls: type[KindSettings] = kind.settings
        if not dataclasses.is_dataclass(cls):
            return self.parse(node_name, raw, source=source)
        return kind, checked_settings(kind.settings, settings)

    def _kind_of(
        self, node_name: str, raw: Any, source: str | None
    ) -> tuple[ModuleKind[Any], dict[str, Any]]:
        """The kind a ``modules:`` block names, and its settings (the block without ``kind:``)."""
        if not isinstance(raw, dict) or "kind" not in raw:
            raise ConfigError(
                f"module {node_name!r}: needs 'kind:' (one of {', '.join(self.names())})", source=source
            )
        name = str(raw["kind"])
        try:
            kind = self.get(name, source=source)
        except ConfigError as exc:
            raise ConfigError([f"module {node_name!r}: {p}" for p in exc.problems], source=source) from exc
        return kind, {key: value for key, value in raw.items() if key != "kind"}

    def check(self, modules: Mapping[str, Any], *, source: str | None = None) -> None:
        """Validate every block of a ``modules:`` section; one ConfigError lists every problem."""
        problems: list[str] = []
        for node_name, raw in modules.items():
            try:
                self.parse(node_name, raw, source=source)
            except ConfigError as exc:
                problems.extend(exc.problems)
        if problems:
            raise ConfigError(problems, source=source)


def built_in_kinds(names: Iterable[str]) -> KindRegistry:
    """A registry of cyborg's own kinds ``names`` alone, imported without reading any package's
    entry points (importlib.metadata). A built-in kind wins over another package's of its name,
    so these are the kinds a full registry finds: for a node of built-in kinds (issue 33)."""
    kinds: dict[str, ModuleKind[Any]] = {}
    for name in names:
        module, _, attribute = BUILT_IN_KINDS[name].partition(":")
        kinds[name] = getattr(importlib.import_module(module), attribute)
    return KindRegistry([], extra=kinds)


def module_kinds(extra: Mapping[str, ModuleKind[Any]] | None = None) -> KindRegistry:
    """The kinds of every installed package (and ``extra``), read from the entry points now."""
    return KindRegistry(extra=extra)


def build_module(
    name: str,
    kind: ModuleKind[Any],
    node: Node,
    settings: KindSettings,
    context: BuildContext,
    *,
    source: str | None = None,
    where: str = "",
) -> Component:
    """Build module ``name`` with its kind's factory; a factory that raises becomes one
    :class:`ConfigError` line naming the module, the reason and the fix (the traceback goes to
    the debug log); an OSError (a full disk) passes through, for the command's own wording. ``where`` (e.g. ``"line 12: "``) says where its block is."""
    try:
        return kind.build(node, settings, context)
    except OSError:
        raise  # a disk or device problem: the commands word it with its own fix (os_problem)
    except Exception as exc:
        log.debug("module %r could not be built", name, exc_info=True)
        if isinstance(exc, CyborgError) and "fix:" in str(exc):  # our own error names its fix already
            raise ConfigError(f"{where}module {name!r} could not be built: {exc}", source=source) from exc
        reason = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
        raise ConfigError(
            f"{where}module {name!r} could not be built: {reason}; fix: correct its settings under "
            f"modules: {name} (or the kind's factory, if they are right); --log-level debug shows the traceback",
            source=source,
        ) from exc
