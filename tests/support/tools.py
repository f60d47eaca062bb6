"""The ``cyborg`` command in a process of its own, as a user runs it from a terminal."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

# The command line of the code under test (PYTHONPATH first), for commands the tests drive.
CYBORG = [sys.executable, "-m", "cyborg.cli"]
# The installed console script, for tests of what a user's shell finds.
CYBORG_SCRIPT = Path(sys.executable).with_name("cyborg")


def pythonpath(*first: Path) -> dict[str, str]:
    """PYTHONPATH with ``first`` before this process's own (which holds the code under test, when set)."""
    return {"PYTHONPATH": os.pathsep.join([*map(str, first), *filter(None, [os.environ.get("PYTHONPATH")])])}


def cyborg(
    *args: str | Path,
    env: dict[str, str] | None = None,
    cwd: Path | None = None,
    timeout: float = 120,
    script: bool = False,
) -> subprocess.CompletedProcess[str]:
    """``cyborg ARGS``, its output captured as text; ``env`` is added to this process's environment.
    ``script``: run the installed console script (what a user's shell finds) instead of ``python -m``."""
    command = [str(CYBORG_SCRIPT)] if script else CYBORG
    return subprocess.run(
        [*command, *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
        env={**os.environ, **(env or {})},
        check=False,
    )


def tool(url: str, *args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """The command tool against the robot at ``url``: ``cyborg ARGS --url URL``. A CYBORG_TOKEN of this
    process's environment is left out: the tool has only the token ``args`` or ``env`` give it."""
    environment = {k: v for k, v in os.environ.items() if k != "CYBORG_TOKEN"}
    return subprocess.run(
        [*CYBORG, *args, "--url", url],
        capture_output=True,
        text=True,
        timeout=30,
        env={**environment, **(env or {})},
        check=False,
    )
