"""An idle ROS 1 node's own threads sleep: rospy's registration thread and our master watch do
not wake twice a second each (issue 33: sixteen processes of a launched robot did, for nothing)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

from cyborg.transport.ros.patches import REGISTRATION_PERIOD
from tests.support.ros import RosSession

LISTEN = 2.5  # seconds the threads' wake-ups are counted


def _wakeups(native_id: int) -> int:
    """Times thread ``native_id`` of this process was switched in so far (voluntary or not)."""
    fields = dict(
        line.split(":", 1) for line in Path(f"/proc/self/task/{native_id}/status").read_text().splitlines()
    )
    return int(fields["voluntary_ctxt_switches"]) + int(fields["nonvoluntary_ctxt_switches"])


def test_rospys_registration_thread_and_the_master_watch_sleep_in_an_idle_node(ros: RosSession) -> None:
    from rospy.impl.registration import RegManager  # type: ignore[import-not-found]

    watched: dict[str, int] = {}
    for thread in threading.enumerate():
        owner = getattr(getattr(thread, "_target", None), "__self__", None)
        if thread.name == "ROS master watch":
            watched["master watch"] = thread.native_id or 0
        elif isinstance(owner, RegManager):
            watched["rospy registration"] = thread.native_id or 0
    assert set(watched) == {"master watch", "rospy registration"}, watched
    before = {name: _wakeups(tid) for name, tid in watched.items()}
    time.sleep(LISTEN)
    woke = {name: _wakeups(tid) - before[name] for name, tid in watched.items()}
    # rospy's own period (0.5 s) would wake each 5 times in LISTEN seconds
    assert woke["rospy registration"] <= LISTEN / REGISTRATION_PERIOD + 1, woke
    assert woke["master watch"] <= 2, woke  # (its first look at the master may fall in here)
