"""The dashboard in a parallel state: one lane per region, what each holds and what is muted.

The packaged monitor robot runs in process; a second dashboard follows it as `cyborg node
cyborg_api` does under ROS (from ``state_change`` alone) and must show the same lanes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aiohttp import ClientSession

from cyborg.app.config import load_config, packaged_config
from cyborg.app.robot import build_robot
from cyborg.transport import topics
from cyborg.transport.messages import String
from cyborg.web.api import RobotAPI
from cyborg.web.dashboard import register
from cyborg.web.ros_view import remote_robot
from tests.support.api import real_time, served


def test_each_region_has_a_lane_and_the_muted_one_says_so_in_process_and_from_state_change(
    tmp_path: Path,
) -> None:
    config = load_config(packaged_config("monitor.yaml"))
    with real_time() as (clock, transport):
        robot = build_robot(config, transport, data_dir=tmp_path)
        events = transport.node("visitor").publisher(topics.REGISTER_EVENT, String)

        async def main() -> None:
            local = RobotAPI(transport.node("cyborg_api"), machine=config.machine)
            register(local, robot)
            mirror_node = transport.node("cyborg_api_remote")
            remote = RobotAPI(mirror_node, machine=config.machine)
            register(remote, remote_robot(mirror_node, config, None))
            async with served(local) as here, served(remote) as there, ClientSession() as session:
                robot.start()

                async def lanes(url: str, want: dict[str, str]) -> tuple[list[dict[str, Any]], Any]:
                    for _ in range(200):
                        async with session.get(url + "/api/health") as response:
                            health = await response.json()
                        found = {lane["region"]: lane["state"] for lane in health["regions"]}
                        if found == want:
                            return health["regions"], health
                        await clock.sleep(0.02)
                    raise AssertionError(f"lanes {health['regions']}, not {want}")

                start = {"monitor": "battery_ok", "behaviour": "idle"}
                first, _ = await lanes(here, start)
                assert [(lane["region"], lane["priority"], lane["muted"]) for lane in first] == [
                    ("monitor", 10, []),
                    ("behaviour", 1, []),
                ]
                async with session.get(here + "/api/status") as response:
                    valid = (await response.json())["valid_events"]
                assert {"battery_low", "music_play", "joke_tell"} <= set(valid), "any region's events"
                events.publish(String("battery_low"))
                await lanes(here, {"monitor": "battery_warning", "behaviour": "idle"})
                events.publish(String("joke_tell"))
                want = {"monitor": "battery_warning", "behaviour": "joke"}
                both, health = await lanes(here, want)
                assert both[0]["holds"] == ["speech"] and both[0]["muted"] == []
                assert both[1]["holds"] == ["speech"] and both[1]["muted"] == ["speech"]
                active = {m["name"] for m in health["modules"] if m["active"]}
                assert active == {"cyborg_battery", "cyborg_joke"}
                assert health["stats"]["resource_mutes"] >= 1
                mirrored, _ = await lanes(there, want)
                assert [{k: v for k, v in lane.items() if k != "seconds_in_state"} for lane in mirrored] == [
                    {k: v for k, v in lane.items() if k != "seconds_in_state"} for lane in both
                ]
                await robot.controller.stop()

        try:
            clock.run(main())
        finally:
            robot.close()
