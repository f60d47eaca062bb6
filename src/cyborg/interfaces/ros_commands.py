"""``cyborg node NAME`` and ``cyborg launch``: the robot as ROS 1 nodes, one process each.

Needs ROS 1 (scripts/install-ros) and a master (``roscore``; ``cyborg launch``
starts one when none answers at ``ROS_MASTER_URI``).
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import random
import signal
import subprocess
import sys
import time
import urllib.parse
import xmlrpc.client
from pathlib import Path

import click

from cyborg.controller.config import LoadedConfig
from cyborg.errors import CyborgError
from cyborg.sim.nodes import API, NodeContext, build_part, part_names
from cyborg.transport.clock import RealClock


def master_uri() -> str:
    return os.environ.get("ROS_MASTER_URI", "http://localhost:11311")


def master_running(uri: str | None = None) -> bool:
    try:
        xmlrpc.client.ServerProxy(uri or master_uri()).getSystemState("/cyborg")
    except (OSError, xmlrpc.client.Error):
        return False
    return True


def require_ros() -> None:
    try:
        import rospy  # type: ignore[import-not-found]  # noqa: F401
    except ImportError:
        raise CyborgError(
            "ROS 1 is not available in this environment; fix: run scripts/install-ros, then "
            "`source .venv/bin/activate`"
        ) from None


def run_node(
    name: str, config: LoadedConfig, data_dir: Path, map_path: Path | None, host: str, port: int, seed: int
) -> None:
    """Run part ``name`` as the ROS node of the same name until SIGINT/SIGTERM."""
    require_ros()
    if not master_running():
        raise CyborgError(
            f"no ROS master answers at {master_uri()}; fix: start roscore, or use `cyborg launch`"
        )
    from cyborg.transport.ros import RosTransport

    clock = RealClock()
    transport = RosTransport(clock, process_name=name)
    context = NodeContext(data_dir=data_dir, rng=random.Random(seed), map_path=map_path)
    part = build_part(name, config, transport, context)

    async def main() -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        api = None
        if name == API:
            from cyborg.interfaces import dashboard
            from cyborg.interfaces.api import RobotAPI
            from cyborg.interfaces.remote import remote_robot

            api_node = transport.node(API)
            api = RobotAPI(api_node, machine=config.machine, emotions=dict(config.model.emotion.prototypes))
            has_base = any(
                isinstance(m, dict) and m.get("kind") == "simulated_base"
                for m in config.model.modules.values()
            )
            mirror = remote_robot(api_node, config, context.occupancy_map() if has_base else None)
            dashboard.register(api, mirror)  # type: ignore[arg-type]
            url = await api.start(host, port)
            click.echo(f"API: {url}", err=True)
        if part.controller is not None:
            part.controller.start()
        click.echo(f"node {name} running", err=True)
        await stop.wait()
        if part.controller is not None:
            await part.controller.stop()
        if api is not None:
            await api.stop()

    try:
        clock.run(main())
    finally:
        transport.shutdown()
        import rospy

        rospy.signal_shutdown("cyborg node stopped")
        clock.close()


def start_master(port: int, log_dir: Path) -> subprocess.Popen[bytes]:
    log_dir.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "ROS_HOME": str(log_dir)}
    process = subprocess.Popen(
        ["roscore", "-p", str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env
    )
    uri = f"http://localhost:{port}"
    deadline = time.monotonic() + 20
    while not master_running(uri):
        if process.poll() is not None or time.monotonic() > deadline:
            raise CyborgError("roscore did not start; fix: check that ROS is installed (scripts/install-ros)")
        time.sleep(0.1)
    return process


def launch(
    config_path: Path, parts: list[str], data_dir: Path, map_path: Path | None, port: int, echo: bool
) -> None:
    """Start a master if needed, then every part as its own `cyborg node` process."""
    require_ros()

    def stop_on_term(signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop_on_term)  # `kill` and `timeout` stop the nodes too
    master = None
    if not master_running():
        parsed = urllib.parse.urlparse(master_uri())
        master = start_master(parsed.port or 11311, data_dir / "ros")
        click.echo(f"started roscore at {master_uri()}")
    processes: list[subprocess.Popen[bytes]] = []
    try:
        for name in parts:
            command = [
                sys.executable,
                "-m",
                "cyborg.interfaces.cli",
                "node",
                name,
                "--config",
                str(config_path),
                "--db",
                str(data_dir),
            ]
            if map_path is not None:
                command += ["--map", str(map_path)]
            if name == API:
                command += ["--port", str(port)]
            processes.append(subprocess.Popen(command, stdout=None if echo else subprocess.DEVNULL))
        click.echo(f"launched {len(processes)} nodes: {', '.join(parts)}")
        while all(p.poll() is None for p in processes):
            time.sleep(0.5)
        failed = [name for name, p in zip(parts, processes, strict=True) if p.poll() is not None]
        raise CyborgError(f"node(s) stopped: {', '.join(failed)}; the whole robot is stopped too")
    except KeyboardInterrupt:
        click.echo("stopping")
    finally:
        for process in processes:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in processes:
            with contextlib.suppress(subprocess.TimeoutExpired):
                process.wait(timeout=10)
            if process.poll() is None:
                process.kill()
        if master is not None:
            master.send_signal(signal.SIGINT)
            master.wait(timeout=10)


def roslaunch_xml(config_path: Path, parts: list[str], data_dir: Path) -> str:
    """A roslaunch file starting the same nodes (for people who prefer roslaunch)."""
    lines = ["<launch>", "  <!-- generated by `cyborg launch --write FILE`; one node per part -->"]
    for name in parts:
        args = f"node {name} --config {config_path} --db {data_dir}"
        lines.append(
            f'  <node name="{name}_launcher" pkg="cyborg_controller" type="cyborg" args="{args}" required="true" output="screen"/>'
        )
    lines.append("</launch>")
    return "\n".join(lines) + "\n"


def all_parts(config: LoadedConfig) -> list[str]:
    return part_names(config)
