"""Run the real ``cyborg`` command in its own process, as a user would, with guards."""

from __future__ import annotations

import os
import resource
import subprocess
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.support.tools import CYBORG_SCRIPT

GUARD_SECONDS = 300  # a guard against a hang, far above what any case takes; not a speed test
MEMORY_LIMIT = 3 * 2**30  # address space: an alias bomb or a giant map fails instead of eating the machine


def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def run_cyborg(
    args: list[str], tmp_path: Path, *, plugins: Path | None = None, log_level: str = "ERROR"
) -> subprocess.CompletedProcess[str]:
    """``plugins``: a folder of installed packages (dist-info and modules) put after the code under test."""
    env = {**os.environ, "CYBORG_DATA_DIR": str(tmp_path / "data"), "NO_COLOR": "1"}
    if plugins is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [os.environ.get("PYTHONPATH"), str(plugins)]))
    return subprocess.run(
        [str(CYBORG_SCRIPT), "--log-level", log_level, *args],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=GUARD_SECONDS,
        preexec_fn=_limit_memory,
        check=False,
    )


@pytest.fixture
def cyborg(tmp_path: Path) -> Callable[..., subprocess.CompletedProcess[str]]:
    """``cyborg(args)`` runs ``cyborg --log-level ERROR *args`` in ``tmp_path`` (its data folder inside);
    keywords as :func:`run_cyborg`."""
    return lambda args, **options: run_cyborg(args, tmp_path, **options)
