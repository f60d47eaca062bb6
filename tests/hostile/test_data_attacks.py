"""Issue 31, item 8: the user's data never quietly goes elsewhere.

Review 3.18: `cyborg db --db notes.txt events list`, a listing command, renamed the user's file to
``notes.txt.corrupt-...`` and put a database in its place. 3.14: a database locked by another
program got the advice "check the disk and the file's permissions". 3.16: deleting the data folder
while the robot ran went unnoticed (``storage.saved`` stayed true).
"""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
import subprocess
import sys
import time
import urllib.request
from collections.abc import Callable
from pathlib import Path
from subprocess import CompletedProcess

import pytest

from cyborg.errors import DatabaseError
from cyborg.motivator.store import ControllerStore
from tests.hostile.robot import ServedRobot

LOCKER = """
import sqlite3, sys, time
connection = sqlite3.connect(sys.argv[1], isolation_level=None)
connection.execute("BEGIN EXCLUSIVE")
print("locked", flush=True)
time.sleep(60)
"""


def test_a_listing_command_leaves_a_file_that_is_no_database_as_it_is(
    tmp_path: Path, cyborg: Callable[..., CompletedProcess[str]]
) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes\n", encoding="utf-8")
    result = cyborg(["db", "--db", str(notes), "events", "list"])
    output = result.stdout + result.stderr
    assert result.returncode == 2 and "Traceback" not in output, output
    assert "notes.txt is not a usable navigation database" in output and "fix:" in output, output
    assert notes.read_text(encoding="utf-8") == "my notes\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_a_locked_database_names_the_program_that_holds_it(
    tmp_path: Path, cyborg: Callable[..., CompletedProcess[str]]
) -> None:
    db = tmp_path / "navigation.db"
    assert cyborg(["db", "--db", str(db), "locations", "list"]).returncode == 0
    locker = subprocess.Popen([sys.executable, "-c", LOCKER, str(db)], stdout=subprocess.PIPE, text=True)
    try:
        assert locker.stdout is not None and locker.stdout.readline() == "locked\n"
        result = cyborg(["db", "--db", str(db), "locations", "add", "lab kitchen"])
    finally:
        locker.kill()
        locker.wait()
    output = result.stdout + result.stderr
    assert result.returncode == 2 and "Traceback" not in output, output
    line = next(line for line in output.splitlines() if line.startswith("Error:"))
    assert "database is locked" in line and f"(process {locker.pid})" in line, line
    assert "fix: stop that program" in line and "permissions" not in line, line


def test_a_deleted_data_folder_is_noticed(tmp_path: Path) -> None:
    data = tmp_path / "data"
    robot = ServedRobot(tmp_path, "--data-dir", str(data))
    try:
        shutil.rmtree(data)
        body = json.dumps({"pleasure": 0.5, "arousal": 0.1, "dominance": 0.2}).encode()
        request = urllib.request.Request(
            robot.url + "/api/emotion/values", data=body, headers={"Content-Type": "application/json"}
        )
        with urllib.request.urlopen(request, timeout=30) as answer:
            answered = json.load(answer)
        assert answered.get("saved") is False, answered
        with urllib.request.urlopen(robot.url + "/api/status", timeout=30) as answer:
            storage = json.load(answer)["storage"]
        assert storage["saved"] is False and "was deleted or replaced" in storage["problem"], storage
        assert "restore the data folder" in storage["fix"], storage
        time.sleep(0.2)
        assert "was deleted or replaced" in robot.text()
        assert robot.terminate() == 0 and "Traceback" not in robot.text(), robot.text()
    finally:
        robot.kill()
        assert os.path.exists(tmp_path)


def test_a_controller_store_of_a_newer_program_is_refused_and_left_in_place(tmp_path: Path) -> None:
    """Review 3.5 (WEAK three rounds): a controller.db whose schema version is newer than this
    program's was used silently (and, with a newer column, moved aside as broken)."""
    path = tmp_path / "controller.db"
    ControllerStore(path).close()
    with sqlite3.connect(path) as conn:
        conn.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
        conn.execute("ALTER TABLE emotion ADD COLUMN mood_of_tomorrow TEXT")
    conn.close()
    with pytest.raises(DatabaseError) as raised:
        ControllerStore(path)
    message = str(raised.value)
    assert f"{path} has schema version 99, newer than this program's" in message, message
    assert "fix: update cyborg, or give --data-dir another folder" in message, message
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith("controller.db")) == [
        "controller.db"
    ]


def test_a_module_whose_database_is_newer_gets_that_fix_alone(tmp_path: Path) -> None:
    """Review 3.4: a navigation.db of a newer program was refused with the right advice, but the
    module-build wrapper then added "fix: correct its settings under modules: cyborg_navigation"."""
    from cyborg.app.context import BuildContext
    from cyborg.app.registry import build_module
    from cyborg.errors import ConfigError
    from cyborg.modules import ModuleKind, ModuleSettings
    from cyborg.transport.clock import VirtualClock
    from cyborg.transport.embedded import EmbeddedTransport

    def build(node: object, settings: object, context: object) -> object:
        raise DatabaseError(f"{tmp_path}/navigation.db has schema version 99, newer than this program's 5; "
                            "fix: update cyborg, or point --db at another file")  # fmt: skip

    kind: ModuleKind[ModuleSettings] = ModuleKind(ModuleSettings, build)  # type: ignore[arg-type]
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    try:
        with pytest.raises(ConfigError) as raised:
            build_module("cyborg_navigation", kind, transport.node("cyborg_navigation"), ModuleSettings(),
                         BuildContext(data_dir=tmp_path))  # fmt: skip
    finally:
        transport.shutdown()
        clock.close()
    message = str(raised.value)
    assert message.count("fix:") == 1 and "fix: update cyborg" in message, message
    assert "module 'cyborg_navigation'" in message, message
