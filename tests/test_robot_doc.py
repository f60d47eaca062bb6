"""docs/robot.md: every command of its ``sh`` blocks runs here, in order, as a user types them.

The ``bash`` blocks need the robot, its network or root (apt, ROSARNL, the unit installed for
real) and are not run. ``cyborg`` is this checkout's command line; the working folder is a fresh
one with the repository's ``src`` in it (the page's paths are the repository's); ALSA's null
device stands in for the sound card, so that the doctor's speaker and microphone checks pass.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from cyborg.app.config import load_config, packaged_config
from cyborg.app.parts import part_names
from tests.support.paths import ROOT
from tests.support.sound import alsa_home

DOC = ROOT / "docs" / "robot.md"
pytestmark = pytest.mark.slow  # a dozen `cyborg` processes: about 15 s


def sh_blocks(text: str) -> list[str]:
    return re.findall(r"^```sh\n(.*?)^```", text, re.S | re.M)


def test_the_bring_up_guide_commands_that_can_run_here_do(tmp_path: Path) -> None:
    blocks = sh_blocks(DOC.read_text(encoding="utf-8"))
    assert len(blocks) >= 5, "the guide lost its runnable blocks"
    (tmp_path / "src").symlink_to(ROOT / "src")
    cyborg = f"{shlex.quote(sys.executable)} -m cyborg.cli"
    script = "\n".join(["set -euo pipefail", f'cyborg() {{ {cyborg} "$@"; }}', *blocks])
    env = {
        **os.environ,
        "XDG_CONFIG_HOME": str(alsa_home(tmp_path / "sound", device=True)),
        "CYBORG_DATA_DIR": str(tmp_path / "default-data"),
        "PYTHONPATH": str(ROOT / "src"),
    }
    done = subprocess.run(
        ["bash", "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=180
    )
    assert done.returncode == 0, (
        f"a command of {DOC.name} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    )
    out = done.stdout
    assert "robot.yaml: valid" in out and "all checks passed" in out
    assert "cafeteria" in out  # the imported places, and the lunch at the cafeteria
    parts = part_names(load_config(packaged_config("robot.yaml")))  # the recorder and the API too
    assert (tmp_path / "robot.launch").read_text().count("<node ") == len(parts)
    assert "ExecStart=" in (tmp_path / "cyborg.service").read_text()
