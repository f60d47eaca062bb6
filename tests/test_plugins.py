"""A module kind from a package installed next to ours is known to every command, with no edit here.

The package is written and pip-installed (into a folder of its own, put on PYTHONPATH) at test
time: a "greeter" that asks for control when it hears "good morning", answers through the
speech gatekeeper and finishes. `cyborg validate`, a scenario run of `cyborg sim` and the
launch file `cyborg launch --write` all find it through its entry point.
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
from pathlib import Path

import pytest

from cyborg.app.registry import ENTRY_POINT_GROUP, KindRegistry
from cyborg.errors import ConfigError
from tests.support import tools

GREETER = '''
"""A greeter module: answers "good morning" (a student's package, not part of cyborg)."""

from pydantic import Field

from cyborg.modules.behaviour import BehaviourModule, GoalContext
from cyborg.modules.kind import ModuleKind, ModuleSettings


class GreeterSettings(ModuleSettings):
    """Greets back whoever says good morning."""

    action: str = Field("greeter/greet", description="action server of the greeting state")
    reply: str = Field("Good morning to you too!", description="what it answers")


class Greeter(BehaviourModule):
    def __init__(self, node, settings):
        super().__init__(node)
        self.settings = settings
        self.serve(settings.action, self.greet)
        self.on_speech_text(self.heard)

    def heard(self, text, info):
        if "good morning" in text.lower():
            self.publish_event("greeting_heard")

    async def greet(self, ctx: GoalContext) -> None:
        self.say(self.settings.reply)
        self.send_emotion(0.05, 0.0, 0.0)
        await ctx.sleep(3.0)


KIND = ModuleKind(GreeterSettings, lambda node, settings, context: Greeter(node, settings))
'''

PYPROJECT = f"""
[build-system]
requires = ["setuptools"]
build-backend = "setuptools.build_meta"

[project]
name = "cyborg-greeter"
version = "0.1.0"

[tool.setuptools]
py-modules = ["greeter"]

[project.entry-points."{ENTRY_POINT_GROUP}"]
greeter = "greeter:KIND"
"""

CONFIG = """
initial: idle
timeouts: {connect: 2.0, preempt: 2.0}
states:
  idle: {action: cyborg_idle/idle, transitions: {greeting_heard: greeting, aborted: idle}}
  greeting:
    action: greeter/greet
    transitions: {succeeded: idle, aborted: idle}
    resources: {speech: greeter}
gatekeepers:
  - {name: cyborg_speech_gatekeeper, input: /text_to_speech, output: /cyborg_tts/say, resource: speech}
modules:
  cyborg_idle: {kind: idle}
  greeter: {kind: greeter, reply: "Good morning, student!"}
  cyborg_tts: {kind: tts}
"""

SCRIPT = """
until: 30
steps:
  - {at: 5, say: "Good morning, robot"}
"""


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder where the greeter package is pip-installed, as a student would install it."""
    source = tmp_path_factory.mktemp("greeter-src")
    (source / "greeter.py").write_text(GREETER)
    (source / "pyproject.toml").write_text(PYPROJECT)
    target = tmp_path_factory.mktemp("site")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(target),
            str(source),
        ],
        check=True,
        capture_output=True,
    )
    return target


def cyborg(site: Path, *args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    """The installed ``cyborg`` with the greeter's folder first on PYTHONPATH."""
    return tools.cyborg(*args, env=tools.pythonpath(site), cwd=cwd, script=True)


@pytest.mark.e2e  # pip-installs a package
def test_validate_knows_the_installed_kind_and_its_settings(site: Path, tmp_path: Path) -> None:
    config = tmp_path / "greeter.yaml"
    config.write_text(CONFIG)
    result = cyborg(site, "validate", config, cwd=tmp_path)
    assert result.returncode == 0, result.stderr + result.stdout

    config.write_text(CONFIG.replace('reply: "Good morning, student!"', "replies: 3"))
    result = cyborg(site, "validate", config, cwd=tmp_path)
    assert result.returncode == 1
    assert "module 'greeter' > replies: unknown key 'replies' (did you mean 'reply'?)" in result.stderr
    assert "the keys here are: action, reply" in result.stderr


def test_without_the_package_the_kind_is_unknown_and_the_error_says_how_to_get_it(tmp_path: Path) -> None:
    config = tmp_path / "greeter.yaml"
    config.write_text(CONFIG)
    result = tools.cyborg("validate", config, cwd=tmp_path, script=True)
    assert result.returncode == 1
    assert "module 'greeter': unknown kind 'greeter'" in result.stderr and "pip install" in result.stderr
    # where to install it: the main venv's Python, which every transport's commands see
    assert "bin/python -m pip install -e PACKAGE_FOLDER" in result.stderr
    assert "one install serves every transport, --ros2 too" in result.stderr


@pytest.mark.e2e  # pip-installs a package
def test_a_kind_installed_in_the_main_venv_is_known_to_the_ros2_venvs_python(
    site: Path, tmp_path: Path
) -> None:
    """The hand-off to .venv-ros2 drops PYTHONPATH but passes the main venv's path in
    $CYBORG_MAIN_PATH: a package installed once there is known on the ROS 2 side too."""
    config = tmp_path / "greeter.yaml"
    config.write_text(CONFIG)
    result = tools.cyborg("kinds", cwd=tmp_path, env={"CYBORG_MAIN_PATH": str(site)})
    assert result.returncode == 0, result.stderr
    assert "greeter" in result.stdout
    result = tools.cyborg("validate", config, cwd=tmp_path, env={"CYBORG_MAIN_PATH": str(site)})
    assert result.returncode == 0, result.stderr + result.stdout


def test_the_ros2_hand_off_passes_the_main_path_and_python(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from cyborg.app import plugin_path
    from cyborg.run import ros2_env

    monkeypatch.setattr(ros2_env, "has_rclpy", lambda: False)
    monkeypatch.setattr(sys, "path", [*sys.path, str(tmp_path)])
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))
    env = ros2_env.ros2_environment()
    assert "PYTHONPATH" not in env, "ROS 1's generated messages would shadow ROS 2's"
    assert str(tmp_path) in env[plugin_path.MAIN_PATH_ENV].split(":")
    assert env[plugin_path.MAIN_PYTHON_ENV] == sys.executable


def test_an_editable_install_in_the_main_venv_is_imported_through_its_pth_file(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """What `pip install -e` leaves in the main venv's site-packages: a dist-info and a .pth naming
    the source folder. A registry in another Python, given that path, finds and imports the kind."""
    source = tmp_path / "src"
    source.mkdir()
    (source / "editable_greeter.py").write_text(GREETER)
    main_site = tmp_path / "site-packages"
    info = main_site / "cyborg_editable_greeter-0.1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: cyborg-editable-greeter\nVersion: 0.1.0\n")
    (info / "entry_points.txt").write_text(
        f"[{ENTRY_POINT_GROUP}]\neditable_greeter = editable_greeter:KIND\n"
    )
    pth = "__editable__.cyborg_editable_greeter-0.1.0.pth"
    (info / "RECORD").write_text(f"{pth},,\ncyborg_editable_greeter-0.1.0.dist-info/METADATA,,\n")
    (main_site / pth).write_text(f"{source}\n")
    monkeypatch.setenv("CYBORG_MAIN_PATH", str(main_site))
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.setattr(sys, "modules", dict(sys.modules))
    registry = KindRegistry()
    assert "editable_greeter" in registry.names()
    assert registry.origin("editable_greeter").startswith("cyborg-editable-greeter 0.1.0")
    kind = registry.get("editable_greeter")
    assert kind.settings.model_validate({}).action == "greeter/greet"  # type: ignore[attr-defined]


@pytest.mark.e2e  # pip-installs a package
def test_a_scenario_runs_the_installed_module(site: Path, tmp_path: Path) -> None:
    config = tmp_path / "greeter.yaml"
    config.write_text(CONFIG)
    script = tmp_path / "morning.yaml"
    script.write_text(SCRIPT)
    transcript = tmp_path / "out.jsonl"
    result = cyborg(
        site,
        *("sim", "--config", config, "--script", script, "--speed", "max", "--transcript", transcript),
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    records = [json.loads(line) for line in transcript.read_text().splitlines()]
    states = [(r["to"], r.get("event")) for r in records if r["type"] == "state"]
    assert ("greeting", "greeting_heard") in states and states[-1][0] == "idle"
    said = [r["text"] for r in records if r["type"] == "say"]
    assert said == ["Good morning, student!"], "the reply passed the speech gatekeeper"


@pytest.mark.e2e  # pip-installs a package; runs a ROS 2 graph from .venv-ros2
def test_a_scenario_over_ros2_runs_the_module_installed_once_in_the_main_venv(
    site: Path, tmp_path: Path
) -> None:
    """One install for every transport: the student installs the greeter into the main venv only
    (here: its folder on this venv's path) and runs the scenario over ROS 2 from the same shell;
    the command hands over to .venv-ros2, whose nodes find the greeter there."""
    config = tmp_path / "greeter.yaml"
    config.write_text(CONFIG)
    script = tmp_path / "morning.yaml"
    script.write_text(SCRIPT)
    transcript = tmp_path / "out.jsonl"
    env = {
        **tools.pythonpath(site),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_DOMAIN_ID": str(random.randint(101, 200)),
        "ROS_LOG_DIR": str(tmp_path / "log"),
    }
    args = ("sim", "--ros2", "--config", config, "--script", script, "--speed", "10")
    result = tools.cyborg(
        *args,
        "--transcript",
        transcript,
        "--db",
        tmp_path / "data",
        env=env,
        cwd=tmp_path,
        timeout=300,
        script=True,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    records = [json.loads(line) for line in transcript.read_text().splitlines()]
    states = [(r["to"], r.get("event")) for r in records if r["type"] == "state"]
    assert ("greeting", "greeting_heard") in states, states
    assert "Good morning, student!" in [r["text"] for r in records if r["type"] == "say"]


@pytest.mark.e2e  # pip-installs a package
def test_the_launch_file_starts_the_installed_module_as_its_own_node(site: Path, tmp_path: Path) -> None:
    config = tmp_path / "greeter.yaml"
    config.write_text(CONFIG)
    launch = tmp_path / "robot.launch"
    result = cyborg(site, "launch", "--config", config, "--write", launch, cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert 'name="greeter"' in launch.read_text()


def test_two_packages_offering_one_kind_is_an_error_naming_both() -> None:
    from importlib.metadata import EntryPoint

    entries = [
        EntryPoint("greeter", "greeter_a:KIND", ENTRY_POINT_GROUP),
        EntryPoint("greeter", "greeter_b:KIND", ENTRY_POINT_GROUP),
    ]
    registry = KindRegistry(entries)
    with pytest.raises(ConfigError, match=r"offered by several packages: .*greeter_a:KIND.*greeter_b:KIND"):
        registry.get("greeter")


def test_an_entry_point_that_is_no_kind_names_the_fix() -> None:
    from importlib.metadata import EntryPoint

    registry = KindRegistry([EntryPoint("broken", "json:dumps", ENTRY_POINT_GROUP)])
    with pytest.raises(ConfigError, match=r"is a function, not a ModuleKind; fix: point the entry point"):
        registry.get("broken")
    registry = KindRegistry([EntryPoint("missing", "no_such_package_here:KIND", ENTRY_POINT_GROUP)])
    with pytest.raises(ConfigError, match=r"could not be imported: .*fix: repair or reinstall"):
        registry.get("missing")
