"""A module's problems reach the dashboard's status while they are open, and leave it when over."""

from __future__ import annotations

from cyborg.modules import ProblemReporter
from cyborg.transport.clock import VirtualClock
from cyborg.transport.embedded import EmbeddedTransport
from cyborg.transport.messages import String
from cyborg.web.api import RobotAPI


def test_open_problems_show_in_the_status_with_their_fix_and_go_when_cleared() -> None:
    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    try:
        api = RobotAPI(transport.node("cyborg_api"))
        tts = ProblemReporter(transport.node("cyborg_tts"))
        nav = ProblemReporter(transport.node("cyborg_navigation"))
        stranger = transport.node("stranger").publisher("/cyborg_diagnostics/problems", String)

        async def main() -> None:
            tts.report("the robot cannot speak aloud: no sound device", "plug in the speaker", key="sound")
            tts.report("the robot cannot speak aloud: no sound device", "plug in the speaker", key="sound")
            nav.report("no robot base: /rosarnl_node/move_base is not offered", "start the base", key="base")
            stranger.publish(String("not json"))
            await clock.sleep(0.1)
            assert api.current_status()["problems"] == {
                "cyborg_tts": [
                    {
                        "key": "sound",
                        "problem": "the robot cannot speak aloud: no sound device",
                        "fix": "plug in the speaker",
                    }
                ],
                "cyborg_navigation": [
                    {
                        "key": "base",
                        "problem": "no robot base: /rosarnl_node/move_base is not offered",
                        "fix": "start the base",
                    }
                ],
            }
            tts.clear("sound")
            await clock.sleep(0.1)
            assert list(api.current_status()["problems"]) == ["cyborg_navigation"]

        clock.run(main())
        kinds = [r["type"] for r in api.records]
        assert kinds.count("problems") == 3, "a repeated report is sent once; the stranger's text is left out"
    finally:
        transport.shutdown()
        clock.close()
