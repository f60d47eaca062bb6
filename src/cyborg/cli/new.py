"""``cyborg new module NAME``: a ready package for a new behaviour module.

It writes, from the templates in ``cyborg/data/templates/module``: the module with its kind
registered as an entry point, a test that uses :mod:`cyborg.testing` and passes, the same
module as a plain rospy node and as a plain rclpy node, a small robot YAML with the block to
add, and a scenario with ``expect`` steps. ``pip install -e`` of the folder makes the kind known to every command.
"""

from __future__ import annotations

import keyword
import re
import string
from importlib import resources
from pathlib import Path

import click

from cyborg.cli.common import fail
from cyborg.errors import CyborgError, InvalidValueError

_NAME = re.compile(r"^[a-z][a-z0-9_]{0,40}$")


def module_files(name: str) -> dict[str, str]:
    """Relative path -> text of every file of the package for module ``name`` (nothing written)."""
    if not _NAME.match(name) or keyword.iskeyword(name) or name.startswith("cyborg"):
        raise InvalidValueError(
            f"{name!r} cannot name a module; fix: use lower-case letters, digits and _, starting with a "
            "letter and not with 'cyborg' (it becomes the node, the kind and the Python package), e.g. greeter"
        )
    values = {
        "name": name,
        "package": name,
        "Class": "".join(part.capitalize() for part in name.split("_")),
        "title": name.replace("_", " ").capitalize(),
    }
    root = resources.files("cyborg") / "data" / "templates" / "module"
    files: dict[str, str] = {}
    for path in _walk(Path(str(root))):
        relative = path.relative_to(Path(str(root))).as_posix().removesuffix(".tmpl").replace("PACKAGE", name)
        files[relative] = string.Template(path.read_text(encoding="utf-8")).substitute(values)
    return files


def _walk(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.tmpl") if p.is_file())


def write_module(name: str, parent: Path, taken: dict[str, str] | None = None) -> Path:
    """Write the package for ``name`` into ``parent/name``; refuses to overwrite anything.

    ``taken``: kinds this installation knows already (name -> where from); a module named like one
    would register a second kind of that name once installed.
    """
    if taken and name in taken:
        raise InvalidValueError(
            f"{name!r} is already a module kind of this installation ({taken[name]}); installed, the new "
            f"package would offer a second kind {name!r}; fix: pick another name, e.g. my_{name} or {name}_2"
        )
    target = parent / name
    if target.exists():
        raise CyborgError(f"{target} exists already; fix: pick another name or folder (nothing was written)")
    files = module_files(name)
    for relative, text in files.items():
        path = target / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return target


@click.group("new")
def new_group() -> None:
    """Start something new from a template: a behaviour module."""


@new_group.command("module")
@click.argument("name")
@click.option(
    "--dir",
    "parent",
    type=click.Path(path_type=Path, file_okay=False),
    default=Path(),
    show_default=True,
    help="folder to create the package in",
)
def new_module(name: str, parent: Path) -> None:
    """Write a ready package for the behaviour module NAME: code, kind, test, YAML, scenario."""
    from cyborg.app.registry import module_kinds

    registry = module_kinds()
    try:
        target = write_module(name, parent, {kind: registry.origin(kind) for kind in registry.names()})
    except (CyborgError, OSError) as exc:
        fail(exc if isinstance(exc, CyborgError) else CyborgError(f"{exc}; fix: check the folder"))
        return
    click.echo(f"wrote {target}/ with the module {name}. Next:")
    for step in (
        f"cd {target}",
        "pip install -e .                       # the kind is now known: cyborg kinds",
        "pytest                                 # its tests, in virtual time",
        "cyborg sim --config robot.yaml         # the robot with its dashboard; say 'hello " + name + "'",
        "cyborg sim --config robot.yaml --script scenario.yaml --speed max",
    ):
        click.echo(f"  {step}")
