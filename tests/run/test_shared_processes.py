"""Which parts of a ROS 2 launch share a process (issue 33: fewer processes, less memory).

The thin modules and the gatekeepers share one; the API and the recorder another (both only
listen to the graph, and both hear the base's pose ten times a second). Each is still its own node.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.app.config import load_config, packaged_config
from cyborg.app.parts import API, CONTROLLER, RECORDER, part_names
from cyborg.errors import CyborgError
from cyborg.run.middleware import ROS2
from cyborg.run.node import NodeOptions, build_node
from cyborg.run.supervisor import Launch, shared_process


def test_the_recorder_shares_the_api_process_and_hears_what_the_launch_tells_it(tmp_path: Path) -> None:
    path = packaged_config("cyborg.yaml")
    config = load_config(path)
    parts = part_names(config)
    hosts = shared_process(config, parts)
    assert hosts[API] == [RECORDER]
    record = ["--record", str(tmp_path / "run.mcap")]
    launch = Launch(
        path, config, parts, tmp_path, middleware=ROS2, hosts=hosts, extra_args={RECORDER: record}, fork=False
    )
    assert RECORDER not in launch.parts and API in launch.parts and CONTROLLER in launch.parts
    command = launch.command(API, None)
    assert command[command.index("--with") + 1 :][:1] == [RECORDER]
    assert command[-2:] == record  # where the recorder records: its host is told


def test_only_the_api_may_host_the_recorder(tmp_path: Path) -> None:
    config = load_config(packaged_config("cyborg.yaml"))
    options = NodeOptions(config=config, data_dir=tmp_path, also=(RECORDER,))
    with pytest.raises(CyborgError, match="the recorder may share the API's"):
        build_node(CONTROLLER, options, ROS2)
