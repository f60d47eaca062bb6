"""A whole `cyborg sim` served on a free port, as a user starts it, for the attacks over HTTP."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

from tests.support.tools import CYBORG

ADDRESS = re.compile(r"dashboard and API: (http://[^/\s]+:(\d+))/(#token=(\S+))?")


class ServedRobot:
    """`cyborg sim ARGS --port 0` in real time; its output goes to ``folder/sim.log``."""

    def __init__(self, folder: Path, *args: str, env: dict[str, str] | None = None) -> None:
        self.output = folder / "sim.log"
        with self.output.open("w") as out:
            self.process = subprocess.Popen(
                [*CYBORG, "sim", "--port", "0", *args],
                stdout=out,
                stderr=subprocess.STDOUT,
                cwd=folder,
                env={**os.environ, "PYTHONUNBUFFERED": "1", "NO_COLOR": "1", **(env or {})},
            )
        deadline = time.monotonic() + 60
        match = None
        while match is None and time.monotonic() < deadline and self.process.poll() is None:
            time.sleep(0.05)
            match = ADDRESS.search(self.text())
        if match is None:
            self.kill()
            pytest.fail("`cyborg sim` did not print its address; its output:\n" + self.text())
        self.url, self.port, self.token = match.group(1), int(match.group(2)), match.group(4)

    def text(self) -> str:
        return self.output.read_text(errors="replace")

    def terminate(self, timeout: float = 20) -> int:
        """SIGTERM, as a service manager stops it; the exit code (the test fails if it does not stop)."""
        self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.kill()
            raise AssertionError(
                f"SIGTERM did not stop the robot within {timeout} s:\n{self.text()[-3000:]}"
            ) from None

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
        self.process.wait(timeout=10)
