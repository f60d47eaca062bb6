"""One part of the robot (``build_part``) as a ROS 2 process of its own, for tests that kill it.

Usage: part_process.py CONFIG PART DATA_DIR. Prints "part ready" once built and started; runs
until SIGTERM/SIGINT (or until it is killed, which is the point).
"""

from __future__ import annotations

import asyncio
import signal
import sys
from pathlib import Path

from cyborg.app.config import load_config
from cyborg.app.context import BuildContext
from cyborg.app.parts import build_part
from cyborg.transport.clock import RealClock
from cyborg.transport.ros2 import Ros2Transport


def main() -> None:
    config_path, name, data_dir = sys.argv[1:4]
    clock = RealClock()
    transport = Ros2Transport(clock)
    part = build_part(name, load_config(config_path), transport, BuildContext(data_dir=Path(data_dir)))

    async def run() -> None:
        stop = asyncio.Event()
        for sig in (signal.SIGINT, signal.SIGTERM):
            asyncio.get_running_loop().add_signal_handler(sig, stop.set)
        if part.controller is not None:
            part.controller.start()
        print("part ready", flush=True)
        await stop.wait()

    try:
        clock.run(run())
    finally:
        part.close()
        transport.close()
        clock.close()


if __name__ == "__main__":
    main()
