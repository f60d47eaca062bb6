"""The ROS 1 master through plain XML-RPC: is one running, its parameters, starting ``roscore``.

No ROS node is needed for any of it, so a launch and a node waiting for its launch can use it
before (or without) joining the graph.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

from cyborg.errors import CyborgError

__all__ = ["Master", "master_running", "master_uri", "start_master"]


def master_uri() -> str:
    """``$ROS_MASTER_URI``, else ROS 1's default."""
    return os.environ.get("ROS_MASTER_URI", "http://localhost:11311")


def master_running(uri: str | None = None) -> bool:
    """True when a ROS 1 master answers at ``uri`` (default :func:`master_uri`)."""
    import xmlrpc.client  # (here: a ROS 2 node imports this module, and needs no XML-RPC)

    try:
        xmlrpc.client.ServerProxy(uri or master_uri()).getSystemState("/cyborg")
    except (OSError, xmlrpc.client.Error):
        return False
    return True


class Master:
    """The parameter server of ``ROS_MASTER_URI``, through plain XML-RPC (no ROS node needed)."""

    def __init__(self, uri: str | None = None, caller: str = "/cyborg_launch") -> None:
        import xmlrpc.client

        self.uri = uri or master_uri()
        self.caller = caller
        self._proxy = xmlrpc.client.ServerProxy(self.uri)

    def get(self, key: str, default: Any = None) -> Any:
        answer: Any = self._proxy.getParam(self.caller, key)
        return answer[2] if answer[0] == 1 else default

    def has(self, key: str) -> bool:
        answer: Any = self._proxy.hasParam(self.caller, key)
        return bool(answer[0] == 1 and answer[2])

    def set(self, key: str, value: Any) -> None:
        self._proxy.setParam(self.caller, key, value)

    def delete(self, key: str) -> None:
        import xmlrpc.client

        with contextlib.suppress(OSError, xmlrpc.client.Error):
            self._proxy.deleteParam(self.caller, key)


def start_master(port: int, log_dir: Path) -> subprocess.Popen[bytes]:
    """Start ``roscore -p port`` (its log under ``log_dir``) and wait until it answers."""
    log_dir.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "ROS_HOME": str(log_dir)}
    process = subprocess.Popen(
        ["roscore", "-p", str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env
    )
    uri = f"http://localhost:{port}"
    deadline = time.monotonic() + 20
    while not master_running(uri):
        if process.poll() is not None or time.monotonic() > deadline:
            process.send_signal(signal.SIGINT)
            raise CyborgError("roscore did not start; fix: check that ROS is installed (scripts/install-ros)")
        time.sleep(0.1)
    return process
