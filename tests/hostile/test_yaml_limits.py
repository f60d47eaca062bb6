"""The YAML limits refuse what is hostile and nothing a real file needs (issue 12, item 5)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from subprocess import CompletedProcess

import pytest

from cyborg.app.config import parse_config
from cyborg.errors import ConfigError
from cyborg.limits import MAX_YAML_BYTES
from cyborg.sim.script import parse_script

SHARED_SETTINGS = """\
initial: idle
states:
  idle:
    action: cyborg_idle/idle
    transitions: &back {aborted: idle, succeeded: idle}
  music:
    action: cyborg_music/play
    transitions:
      <<: *back
      music_play: music
"""


def test_anchors_aliases_and_merge_keys_still_work() -> None:
    loaded = parse_config(SHARED_SETTINGS, "shared.yaml")
    assert loaded.machine.states["music"].transitions == {
        "aborted": "idle",
        "succeeded": "idle",
        "music_play": "music",
    }


def test_a_file_over_the_size_limit_is_refused_naming_the_limit() -> None:
    text = "until: 10\nsteps:\n" + "  - at: 1\n    say: hello there\n" * (MAX_YAML_BYTES // 30)
    with pytest.raises(ConfigError, match=f"over the limit of {MAX_YAML_BYTES:,} bytes; fix:"):
        parse_script(text, "long.yaml")


def test_a_long_script_within_the_limit_loads(tmp_path: Path) -> None:
    steps = "".join(f"  - at: {i}\n    say: step {i}\n" for i in range(20_000))
    assert len(parse_script(f"until: 30000\nsteps:\n{steps}", "long.yaml").steps) == 20_000


def test_brackets_nested_50000_deep_are_refused_not_a_crash(
    tmp_path: Path, cyborg: Callable[[list[str]], CompletedProcess[str]]
) -> None:
    # libyaml's composer recurses in C: this depth crashes the process unless the Python loader reads it.
    deep = tmp_path / "deep.yaml"
    deep.write_text("navigation: " + "[" * 50_000 + "]" * 50_000 + "\n", encoding="utf-8")
    result = cyborg(["validate", str(deep)])
    assert result.returncode == 1, result.stderr
    assert "nested too deeply" in result.stderr and "fix: flatten" in result.stderr
