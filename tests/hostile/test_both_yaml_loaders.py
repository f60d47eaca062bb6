"""Every YAML file the robot reads goes through libyaml's C loader when it can, and the limits hold
the same either way: each hostile YAML file of the corpus, and the limit and configuration tests
(tests/controller/test_config.py runs with both loaders too), give the same answer with the C
loader and the Python one."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from cyborg.configfile import reader
from cyborg.configfile.reader import load_yaml, read_yaml_file, yaml_loader
from cyborg.errors import ConfigError

FILES = Path(__file__).parent / "files"
HOSTILE_YAML = sorted(path for path in FILES.glob("*.yaml"))


def outcome(path: Path) -> tuple[str, object]:
    try:
        return "loaded", read_yaml_file(path)
    except ConfigError as exc:
        return "refused", str(exc)


def test_the_c_loader_is_installed_and_chosen() -> None:
    """A missing libyaml (a PyYAML built without it) would silently make every load slower."""
    assert hasattr(yaml, "CSafeLoader"), "PyYAML has no C loader: install it with libyaml (scripts/setup)"
    assert yaml_loader("initial: idle\nstates: {idle: {action: a/b}}\n") is yaml.CSafeLoader


@pytest.mark.parametrize("path", HOSTILE_YAML, ids=lambda path: path.name)
def test_a_hostile_file_gets_the_same_answer_from_both_loaders(
    path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with_c = outcome(path)
    monkeypatch.setattr(reader, "yaml_loader", lambda text: yaml.SafeLoader)
    assert outcome(path) == with_c


@pytest.mark.parametrize(
    "text, says",
    [
        ("a: 1\nb: 2\na: 3\n", "line 3"),  # a duplicate key names its line
        ("a: &x [1, 2]\nb: *x\nc: {d: 1, d: 2}\n", "line 3"),
        ("a: &x [*x]\n", "refers to the mapping or list that contains it"),
        (
            "a: &a [1,1,1,1,1,1,1,1,1]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\nc: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]\n"
            "d: &d [*c,*c,*c,*c,*c,*c,*c,*c,*c]\ne: &e [*d,*d,*d,*d,*d,*d,*d,*d,*d]\n"
            "f: &f [*e,*e,*e,*e,*e,*e,*e,*e,*e]\ng: [*f,*f,*f,*f,*f,*f,*f,*f,*f]\n",
            "expands to over",
        ),
    ],
)
@pytest.mark.parametrize("loader", ["C", "Python"])
def test_duplicate_keys_and_alias_bombs_are_refused_by_both_loaders(
    text: str, says: str, loader: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    if loader == "Python":
        monkeypatch.setattr(reader, "yaml_loader", lambda text: yaml.SafeLoader)
    else:
        assert reader.yaml_loader(text) is yaml.CSafeLoader
    with pytest.raises(ConfigError, match=says):
        load_yaml(text, "x.yaml")
