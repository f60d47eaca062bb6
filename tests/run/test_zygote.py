"""The launch's zygote forks each node as ``python -m cyborg.cli ARGV`` and tells how it ended."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from cyborg.run.zygote import Zygote


def test_forked_commands_end_with_their_exit_codes_before_and_after_the_slim_and_the_zygote_with_its_launch(
    tmp_path: Path,
) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
    zygote = Zygote(sys.executable, env, "ros1", echo=False)  # (without ROS it preloads what it can)
    try:
        helped = zygote.spawn(["--help"])
        wrong = zygote.spawn(["no-such-command"])
        assert helped.wait(timeout=60) == 0
        assert wrong.wait(timeout=60) == 2  # click's usage error, as from a freshly started process
        assert helped.poll() == 0 and helped.pid != wrong.pid
        running = zygote.spawn(["sim", "--db", str(tmp_path), "--duration", "600"])
        try:
            assert os.getpgid(running.pid) == os.getpgid(0)  # Ctrl-C in the launch's terminal reaches it
            with pytest.raises(subprocess.TimeoutExpired):
                running.wait(timeout=0.05)
            zygote.slim()  # the launch has started every node: the zygote drops its imports (exec)
            again = zygote.spawn(["no-such-command"])  # a node started again after the slim: afresh
            assert again.wait(timeout=60) == 2
            cmdline = Path(f"/proc/{zygote._process.pid}/cmdline").read_bytes().split(b"\0")
            assert b"fresh" in cmdline  # the same process, the small program
        finally:
            running.send_signal(signal.SIGKILL)
        assert running.wait(timeout=30) == -signal.SIGKILL  # forked before the slim, still told
    finally:
        zygote.close()
    assert not zygote.alive
