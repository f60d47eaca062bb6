"""The module author's surface: cyborg.modules exports what a module needs, each with a docstring."""

from __future__ import annotations

import inspect

import cyborg.modules
import cyborg.testing

MODULE_NAMES = [
    "Abort",
    "BehaviourModule",
    "BuildContext",
    "Component",
    "Field",
    "GoalContext",
    "MessageInfo",
    "ModuleKind",
    "ModuleSettings",
    "Node",
    "Outcome",
    "ProblemReporter",
]


def test_the_exported_names_are_pinned() -> None:
    """Removing or renaming one breaks students' modules: do it on purpose, here and in docs/modules.md."""
    assert cyborg.modules.__all__ == MODULE_NAMES
    assert cyborg.testing.__all__ == ["Feedback", "Goal", "GoalStatus", "ModuleHarness", "wait_until"]
    for name in MODULE_NAMES:
        assert hasattr(cyborg.modules, name)


def test_every_public_method_an_author_calls_says_what_a_user_sees() -> None:
    from cyborg.modules import BehaviourModule, GoalContext

    for cls in (BehaviourModule, GoalContext, cyborg.testing.ModuleHarness):
        for name, member in inspect.getmembers(cls):
            if name.startswith("_") or not (inspect.isfunction(member) or isinstance(member, property)):
                continue
            assert (member.__doc__ or "").strip(), f"{cls.__name__}.{name} has no docstring"
    say = inspect.getdoc(BehaviourModule.say) or ""
    assert "/text_to_speech" in say and "gatekeeper" in say and "speech" in say
    event = inspect.getdoc(BehaviourModule.publish_event) or ""
    assert "register_event" in event and "transition of the active state" in event
    emotion = inspect.getdoc(BehaviourModule.send_emotion) or ""
    assert "emotional_feedback" in emotion
