"""The module author's harness (cyborg.testing): what a module says, publishes and feels, in virtual time."""

from __future__ import annotations

import pytest

from cyborg.errors import ConfigError
from cyborg.modules import BehaviourModule, GoalContext, Node
from cyborg.testing import GoalStatus, ModuleHarness


class Echo(BehaviourModule):
    """Asks for its state on "echo", repeats the last sentence it heard in a mood-dependent way."""

    def __init__(self, node: Node) -> None:
        super().__init__(node)
        self.heard = ""
        self.moods: list[tuple[str, str]] = []
        self.serve("echo/repeat", self.repeat)
        self.on_speech_text(self.listen)
        self.on_emotion_change(lambda emotion, previous: self.moods.append((previous, emotion)))

    def listen(self, text: str, info: object) -> None:
        self.heard = text
        if text.startswith("echo"):
            self.publish_event("echo_wanted")

    async def repeat(self, ctx: GoalContext) -> None:
        self.say(f"{self.emotion}: {self.heard}")
        self.send_emotion(0.1, 0.0, -0.1)
        await ctx.sleep(2.0)


def test_the_probes_see_what_the_module_does_and_nothing_else() -> None:
    with ModuleHarness(Echo) as echo:
        echo.hear("echo this")
        assert echo.events == ["echo_wanted"]
        echo.set_emotion("elated")
        assert echo.module.moods == [("neutral", "elated")]  # type: ignore[attr-defined]
        goal = echo.start()
        assert goal.status is GoalStatus.ACTIVE and echo.said == ["elated: echo this"]
        echo.run(1.9)
        assert not goal.done
        echo.run(0.2)
        assert goal.status is GoalStatus.SUCCEEDED  # type: ignore[comparison-overlap]  # run() changed it
        assert [f.pad for f in echo.feedback] == [(0.1, 0.0, -0.1)]
        echo.hear("not for me")
        assert echo.events == ["echo_wanted"], "a sentence that is no request publishes nothing"


def test_a_preempted_goal_ends_at_once_and_says_nothing_more() -> None:
    with ModuleHarness(Echo) as echo:
        goal = echo.start("echo/repeat")
        goal.cancel()
        echo.run(0.001)
        assert goal.status is GoalStatus.PREEMPTED
        echo.run(5)
        assert echo.said == ["neutral: "]


def test_an_installed_kind_is_built_from_its_yaml_settings() -> None:
    with ModuleHarness("question", {"action": "quiz/ask", "question": "Ready?", "answer_seconds": 3}) as quiz:
        goal = quiz.start()
        assert quiz.said == ["Ready?"]
        quiz.run(3.5)
        assert goal.status is GoalStatus.SUCCEEDED  # type: ignore[comparison-overlap]  # run() changed it
        assert [f.pad for f in quiz.feedback] == [(-0.01, -0.04, 0.01)], "nobody answered: it cools down"


def test_bad_settings_and_an_unclear_action_name_the_fix() -> None:
    with pytest.raises(ConfigError, match=r"question: missing 'question'"):
        ModuleHarness("question", {"action": "quiz/ask"})
    with (
        ModuleHarness("placeholder", {"servers": [{"action": "a/x"}, {"action": "a/y"}]}) as two,
        pytest.raises(ConfigError, match=r"serves \['a/x', 'a/y'\]; fix: name the action"),
    ):
        two.start()
