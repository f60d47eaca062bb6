"""The real robot's configuration (robot.yaml) is the simulated one's robot with real parts.

Same states, transitions, motivator and gatekeepers as cyborg.yaml (a change to one that forgets
the other fails here); no simulated part; text-to-speech aloud, the ears on the microphone, and
the navigation module's limits for a base that can fail. ``--config robot`` finds it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.app.config import load_config, packaged_config
from cyborg.app.registry import module_kinds
from cyborg.cli.common import load_or_default


def test_robot_yaml_has_the_simulated_robots_machine_and_only_real_parts() -> None:
    sim = load_config(packaged_config("cyborg.yaml")).model
    robot = load_config(packaged_config("robot.yaml")).model
    for section in ("initial", "timeouts", "states", "motivator", "gatekeepers"):
        assert getattr(robot, section) == getattr(sim, section), (
            f"robot.yaml's {section} differs from cyborg.yaml's"
        )
    kinds = {name: raw["kind"] for name, raw in robot.modules.items()}
    assert "simulated_base" not in kinds.values()
    assert {n: k for n, k in kinds.items() if n != "cyborg_speech"} == {
        n: raw["kind"] for n, raw in sim.modules.items() if raw["kind"] != "simulated_base"
    }
    assert robot.modules["cyborg_tts"]["play_audio"] is True
    assert robot.modules["cyborg_speech"] == {"kind": "speech_input", "source": "microphone"}
    _, navigation = module_kinds().parse("cyborg_navigation", robot.modules["cyborg_navigation"])
    assert navigation.base_answer_timeout and navigation.pose_timeout  # type: ignore[attr-defined]


def test_a_packaged_configuration_is_picked_by_its_name_unless_a_file_has_that_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert Path(load_or_default(Path("robot")).source) == packaged_config("robot.yaml")
    monkeypatch.chdir(tmp_path)
    (tmp_path / "robot").write_text(packaged_config("demo.yaml").read_text())
    assert load_or_default(Path("robot")).source.endswith("robot")  # the user's own file wins
