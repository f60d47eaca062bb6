"""``cyborg launch``'s own process joins no graph, so it does not carry rospy (issue 33).

rospy brings actionlib, genpy and numpy: 15 MiB of the launcher's memory for as long as the
robot ran, only to check that ROS 1 is installed. The nodes import it; the launcher finds it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from tests.support.ros import RosSession

# What `cyborg launch` does with the graph before and after its nodes run (cyborg.run.supervisor).
LAUNCH_GRAPH = """
import json, sys
from pathlib import Path
from cyborg.run.middleware import ROS1
graph = ROS1.launch_graph(Path(sys.argv[1]), print)
graph.open(None)
graph.close()
print(json.dumps(sorted(name for name in ("rospy", "actionlib", "genpy", "numpy") if name in sys.modules)))
"""


def test_the_launcher_prepares_a_ros1_graph_without_importing_rospy(ros: RosSession, tmp_path: Path) -> None:
    env = {**os.environ, "ROS_MASTER_URI": ros.master.uri}
    result = subprocess.run(
        [sys.executable, "-c", LAUNCH_GRAPH, str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        env=env,
    )
    assert result.returncode == 0, result.stderr[-2000:]
    assert json.loads(result.stdout.strip().splitlines()[-1]) == []
