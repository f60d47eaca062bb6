"""Start the robot when its computer boots: a systemd unit that runs ``cyborg launch``.

:func:`unit_text` writes the unit (pure: no I/O): ``cyborg launch`` with the configuration and
data folder given, restarted on failure, its output in the journal, stopped with SIGINT as from
a terminal (the launch then stops every node), the ROS environment of the shell it was installed
from (ROS_MASTER_URI, ROS_IP/ROS_HOSTNAME, ROS_DOMAIN_ID, ...) written into it. :class:`Service`
installs it (system-wide, or for the user with ``user``), enables and starts it, tells its status
and removes it, through ``systemctl``. Where systemd is not running (a container, WSL without
it) it refuses with a :class:`~cyborg.errors.CyborgError` naming what to do instead.
"""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from cyborg.errors import CyborgError
from cyborg.run.middleware import Middleware

__all__ = ["SYSTEMD_RUN_DIR", "Service", "require_systemd", "unit_text"]

SYSTEMD_RUN_DIR = Path("/run/systemd/system")
"""Present exactly when systemd is the running init system (as sd_booted(3) checks)."""
UNIT = "cyborg.service"
CARRIED_PREFIXES = ("ROS_", "CYBORG_")
CARRIED = ("PYTHONPATH", "LD_LIBRARY_PATH", "CMAKE_PREFIX_PATH", "PULSE_SERVER")
"""Variables of the installing shell the robot needs: ROS's (ROS_MASTER_URI, ROS_IP or ROS_HOSTNAME,
ROS_DOMAIN_ID; Noetic's setup.bash also sets PYTHONPATH and LD_LIBRARY_PATH), ours, and the sound
server's."""


def require_systemd(run_dir: Path | None = None) -> None:
    """Raise unless systemd runs here (and ``systemctl`` is installed)."""
    if not (run_dir or SYSTEMD_RUN_DIR).is_dir() or shutil.which("systemctl") is None:
        raise CyborgError(
            "systemd is not running on this machine (no /run/systemd/system), so the robot cannot be "
            "started at boot by `cyborg service`; fix: use a robot computer that boots with systemd "
            "(Ubuntu does), or start `cyborg launch --config robot` from your own init system "
            "(`cyborg service install --write FILE` writes the unit for reference)"
        )


def _quote(value: str) -> str:
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"').replace("%", "%%") + '"'


def unit_text(
    command: Sequence[str],
    *,
    environment: Mapping[str, str],
    user: str | None,
    description: str = "NTNU Cyborg: the behaviour controller and its nodes (cyborg launch)",
) -> str:
    """The unit that runs ``command`` (absolute paths) with ``environment``, as ``user`` (None:
    a user unit, which runs as its owner)."""
    lines = [
        "# Written by `cyborg service install`; `cyborg service uninstall` removes it.",
        "[Unit]",
        f"Description={description}",
        "Wants=network-online.target",
        "After=network-online.target sound.target",
        "StartLimitIntervalSec=300",
        "StartLimitBurst=10",
        "",
        "[Service]",
        "Type=exec",
    ]
    if user is not None:
        lines.append(f"User={user}")
    lines += [f"Environment={_quote(f'{key}={value}')}" for key, value in sorted(environment.items())]
    lines += [
        "ExecStart=" + " ".join(_quote(part) if (" " in part or '"' in part) else part for part in command),
        "Restart=on-failure",
        "RestartSec=5",
        "KillSignal=SIGINT",
        "TimeoutStopSec=40",
        "StandardOutput=journal",
        "StandardError=journal",
        "SyslogIdentifier=cyborg",
        "",
        "[Install]",
        f"WantedBy={'multi-user.target' if user is not None else 'default.target'}",
        "",
    ]
    return "\n".join(lines)


def launch_command(config: Path, data_dir: Path, middleware: Middleware, port: int) -> list[str]:
    """``cyborg launch`` by this Python, with absolute paths (a unit has no working directory)."""
    command = [sys.executable, "-m", "cyborg.cli", "launch", "--config", str(config.resolve())]
    command += ["--db", str(data_dir.resolve()), "--port", str(port)]
    return [*command, *middleware.node_arguments]


def carried_environment(data_dir: Path, source: Mapping[str, str] | None = None) -> dict[str, str]:
    """What the unit's process needs of this shell's environment."""
    env = os.environ if source is None else source
    carried = {
        key: value
        for key, value in env.items()
        if value and (key in CARRIED or key.startswith(CARRIED_PREFIXES))
    }
    carried["PATH"] = os.pathsep.join(
        [str(Path(sys.executable).parent), "/usr/local/bin", "/usr/bin", "/bin"]
    )
    carried["CYBORG_DATA_DIR"] = str(data_dir.resolve())
    carried["PYTHONUNBUFFERED"] = "1"
    if env.get("HOME"):
        carried["HOME"] = env["HOME"]  # ~/.ros/log, the speech model's cache
    return carried


@dataclass
class Service:
    """The robot's unit, system-wide (``/etc/systemd/system``) or the user's (``user``)."""

    user: bool = False

    @property
    def path(self) -> Path:
        if self.user:
            config = Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config")
            return config / "systemd" / "user" / UNIT
        return Path("/etc/systemd/system") / UNIT

    def _systemctl(self, *args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
        command = ["systemctl", *(["--user"] if self.user else []), *args]
        done = subprocess.run(command, capture_output=True, text=True, timeout=60)
        if check and done.returncode:
            raise CyborgError(
                f"`{shlex.join(command)}` failed: {(done.stderr or done.stdout).strip()}; fix: "
                + (
                    "run it as root (sudo), or install a user unit with --user"
                    if not self.user
                    else "check the output"
                )
            )
        return done

    def install(self, text: str, *, start: bool = True) -> None:
        """Write the unit, reload systemd, enable it (and start it now, with ``start``)."""
        require_systemd()
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.path.write_text(text, encoding="utf-8")
        except OSError as exc:
            raise CyborgError(
                f"cannot write {self.path} ({exc.strerror}); fix: run as root (sudo), or use --user"
            ) from exc
        self._systemctl("daemon-reload")
        self._systemctl("enable", *(["--now"] if start else []), UNIT)

    def status(self) -> tuple[bool, str]:
        """Whether the unit is active, and systemd's account of it with its last log lines."""
        require_systemd()
        if not self.path.exists():
            return False, f"not installed ({self.path} is missing); fix: cyborg service install"
        active = self._systemctl("is-active", "--quiet", UNIT, check=False).returncode == 0
        shown = self._systemctl("status", "--no-pager", "--lines=15", UNIT, check=False)
        return active, (shown.stdout + shown.stderr).strip()

    def uninstall(self) -> bool:
        """Stop and disable the unit and remove its file; False when it was not installed."""
        require_systemd()
        if not self.path.exists():
            return False
        self._systemctl("disable", "--now", UNIT, check=False)
        self.path.unlink()
        self._systemctl("daemon-reload")
        return True
