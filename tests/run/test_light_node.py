"""A module's or gatekeeper's node loads what its part runs, not the robot (issue 33).

``cyborg launch`` validates the configuration once and tells each node so (``--checked DIGEST``);
a thin node then reads a sketch of the file and builds its part without the controller, the
emotion system, the motivator or the configuration models. A file changed since it was validated
is validated again, whole.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from cyborg.app.config import packaged_config
from cyborg.app.sketch import ConfigSketch, text_digest
from cyborg.cli.ros import _node_config
from cyborg.errors import ConfigError, CyborgError

ROOT = Path(__file__).resolve().parents[2]

# What a thin node must not load: the parts it does not run, and the configuration models.
NOT_LOADED = (
    "cyborg.controller",
    "cyborg.emotion",
    "cyborg.motivator",
    "cyborg.app.robot",
    "cyborg.app.config",
    "cyborg.observe",
    "cyborg.maps",
    "cyborg.run.local",
    "cyborg.run.supervisor",
    "cyborg.run.scenario",
    "cyborg.sim",
    "cyborg.web.api",
    "sqlite3",
)

# Builds parts the way `cyborg node NAME --checked DIGEST` does (cyborg.run.node.build_node), on
# an in-process transport: the ROS transports import nothing of the app (tests/test_layers.py).
BUILD = """
import json, sys
from pathlib import Path
from cyborg.cli import main  # the console script's import
from cyborg.cli.ros import _node_config
from cyborg.run.middleware import Ros1
from cyborg.run.node import NodeOptions, build_node
from cyborg.transport.embedded import EmbeddedTransport

class InProcess(Ros1):
    def transport(self, clock, node_name, *, use_sim_time=False, also=()):
        return EmbeddedTransport(clock)

    def part_built(self, node_name):
        return None

path, digest, data = Path(sys.argv[1]), sys.argv[2], Path(sys.argv[3])
built = {}
for group in sys.argv[4:]:  # NAME, or NAME+HOSTED+...: one process hosting several parts
    name, *also = group.split("+")
    config = _node_config([name, *also], path, digest)
    node = build_node(name, NodeOptions(config=config, data_dir=data, also=tuple(also)), InProcess())
    built[group] = [[type(c).__name__, c.node.name] for c in node.part.components]
    node.close()
print(json.dumps({"built": built, "modules": sorted(sys.modules)}))
"""


def _build_in_fresh_python(config: Path, names: list[str], data: Path) -> dict[str, object]:
    digest = text_digest(config.read_text(encoding="utf-8"))
    result = subprocess.run(
        [sys.executable, "-c", BUILD, str(config), digest, str(data), *names],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    answer: dict[str, object] = json.loads(result.stdout.strip().splitlines()[-1])
    return answer


def test_a_launched_module_node_and_gatekeeper_load_neither_the_controller_nor_the_config_models(
    tmp_path: Path,
) -> None:
    shared = "cyborg_idle+cyborg_joke+cyborg_tts+cyborg_speech_gatekeeper"  # ROS 2's shared process
    names = ["cyborg_music", "cyborg_speech_gatekeeper", shared]
    answer = _build_in_fresh_python(packaged_config("cyborg.yaml"), names, tmp_path)
    built = answer["built"]
    assert isinstance(built, dict)
    assert built["cyborg_speech_gatekeeper"] == [["Gatekeeper", "cyborg_speech_gatekeeper"]]
    assert [node for _, node in built["cyborg_music"]] == ["cyborg_music"]
    # one process, each part on a node of its own name: a gatekeeper still tells them apart
    assert [node for _, node in built[shared]] == shared.split("+"), built[shared]
    loaded = answer["modules"]
    assert isinstance(loaded, list)
    found = sorted(m for m in loaded if any(m == bad or m.startswith(bad + ".") for bad in NOT_LOADED))
    assert found == [], f"a thin node loads what it does not run: {found}"


# What `python -m cyborg.run.launched node NAME ...` (a launch's thin part) imports and builds,
# on an in-process transport: its arguments read as the launch writes them (Launch.command).
LAUNCHED = """
import json, sys
from cyborg.run import launched
from cyborg.run.middleware import Ros1
from cyborg.run.node import build_node
from cyborg.transport.embedded import EmbeddedTransport

class InProcess(Ros1):
    def transport(self, clock, node_name, *, use_sim_time=False, also=()):
        return EmbeddedTransport(clock)

    def part_built(self, node_name):
        return None

built = {}
for line in sys.stdin:
    node = launched.parse_launched(json.loads(line))
    options = launched._options(node)
    part = build_node(node.name, options, InProcess())
    built[node.name] = [[type(c).__name__, c.node.name] for c in part.part.components]
    part.close()
print(json.dumps({"built": built, "modules": sorted(sys.modules)}))
"""


def test_a_launched_thin_node_loads_neither_pydantic_nor_click(tmp_path: Path) -> None:
    from cyborg.app.config import load_config
    from cyborg.run.middleware import ROS1, Ros1
    from cyborg.run.supervisor import Launch, shared_process

    config = load_config(packaged_config("cyborg.yaml"))
    parts = ["cyborg_idle", "cyborg_joke", "cyborg_music", "cyborg_conversation", "cyborg_tts"]
    parts += ["cyborg_speech_gatekeeper", "cyborg_navigation", "cyborg_controller"]
    robot = Launch(Path(config.source), config, parts, tmp_path, middleware=ROS1)
    commands = {name: robot.command(name, None) for name in robot.parts}
    # the parts that run code of their own (and what a plug-in kind is) start as `cyborg node`
    assert {name for name, command in commands.items() if command[2] == "cyborg.cli"} == {
        "cyborg_navigation",
        "cyborg_controller",
    }
    thin = [command[3:] for command in commands.values() if command[2] == "cyborg.run.launched"]

    class Hosting(Ros1):  # ROS 2's shared process (--with), its command line read the same way
        hosts_many = True

    hosts = shared_process(config, parts[:6])
    hosting = Launch(Path(config.source), config, parts[:6], tmp_path, middleware=Hosting(), hosts=hosts)
    thin.append(hosting.command(hosting.parts[0], None)[3:])
    result = subprocess.run(
        [sys.executable, "-c", LAUNCHED],
        input="".join(json.dumps(argv) + "\n" for argv in thin),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    answer = json.loads(result.stdout.strip().splitlines()[-1])
    assert answer["built"]["cyborg_joke"] == [["QuestionModule", "cyborg_joke"]]
    assert [node for _, node in answer["built"]["cyborg_idle"]] == parts[:6]
    heavy = ("pydantic", "pydantic_core", "click", "importlib.metadata", "xmlrpc", *NOT_LOADED)
    found = sorted(m for m in answer["modules"] if any(m == bad or m.startswith(bad + ".") for bad in heavy))
    assert found == [], f"a launched thin node loads what it does not need: {found}"


def test_ros1_refuses_to_host_several_parts_in_one_process() -> None:
    from cyborg.run.middleware import ROS1
    from cyborg.transport.clock import RealClock

    with pytest.raises(CyborgError, match="one node per process"):
        ROS1.transport(RealClock(), "cyborg_idle", also=("cyborg_joke",))


def test_a_node_validates_the_whole_file_when_it_changed_since_the_launch_checked_it(
    tmp_path: Path,
) -> None:
    config = tmp_path / "robot.yaml"
    text = packaged_config("demo.yaml").read_text(encoding="utf-8")
    config.write_text(text, encoding="utf-8")
    digest = text_digest(text)
    assert isinstance(_node_config(["cyborg_joke"], config, digest), ConfigSketch)
    assert not isinstance(_node_config(["cyborg_joke", "cyborg_controller"], config, digest), ConfigSketch)
    assert not isinstance(_node_config(["cyborg_joke"], config, None), ConfigSketch)  # by hand: whole

    config.write_text(text.replace("initial:", "initial_state:"), encoding="utf-8")
    with pytest.raises(ConfigError, match="initial_state"):
        _node_config(["cyborg_joke"], config, digest)  # edited after the launch: checked again, whole


def test_the_built_in_kinds_table_is_the_one_of_the_entry_points() -> None:
    import tomllib

    from cyborg.app.registry import BUILT_IN_KINDS, ENTRY_POINT_GROUP

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert project["project"]["entry-points"][ENTRY_POINT_GROUP] == BUILT_IN_KINDS


def test_a_launched_node_makes_the_settings_the_launch_validated(tmp_path: Path) -> None:
    """What the node makes of a block without pydantic is what validation made of it, lax input too."""
    from cyborg.app.config import load_config
    from cyborg.app.registry import built_in_kinds, module_kinds
    from cyborg.run.supervisor import THIN_KINDS

    registry = module_kinds()
    blocks = {
        f"{file}:{name}": raw
        for file in ("cyborg.yaml", "demo.yaml", "robot.yaml", "monitor.yaml")
        for name, raw in load_config(packaged_config(file)).model.modules.items()
        if raw["kind"] in THIN_KINDS
    }
    blocks["lax_placeholder"] = {
        "kind": "placeholder",
        "servers": [
            {"action": "a/b", "duration": "5", "emotion": [1, "0.5", 0], "honour_cancel": "no"},
            {"action": "c/d", "honour_cancel": 1.0},
        ],
    }
    blocks["lax_tts"] = {"kind": "tts", "queue_size": "3", "play_audio": 0}
    blocks["lax_music"] = {"kind": "music", "play_audio": "off", "feedback": [0, 0.1, 1]}
    blocks["lax_script"] = {"kind": "event_script", "events": ["x", "y"], "every": 2}
    assert {raw["kind"] for raw in blocks.values()} == THIN_KINDS
    light = built_in_kinds(THIN_KINDS)
    for name, raw in blocks.items():
        validated = registry.parse(name, raw)[1]
        made = light.parse_checked(name, raw)[1]
        assert made == validated, name
        assert repr(made) == repr(validated), name  # the same types too (5.0, not "5"; tuples)


def test_a_launched_node_whose_file_changed_since_the_launch_is_validated_whole_by_cyborg_node(
    tmp_path: Path,
) -> None:
    config = tmp_path / "robot.yaml"
    text = packaged_config("demo.yaml").read_text(encoding="utf-8")
    config.write_text(text.replace("initial:", "initial_state:"), encoding="utf-8")
    argv = [
        "node",
        "cyborg_joke",
        "--config",
        str(config),
        "--db",
        str(tmp_path),
        "--checked",
        text_digest(text),
    ]
    result = subprocess.run(
        [sys.executable, "-m", "cyborg.run.launched", *argv],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        cwd=ROOT,
    )
    assert result.returncode == 1, result.stderr[-2000:]
    assert "initial_state" in result.stderr and "fix:" in result.stderr, result.stderr[-2000:]
