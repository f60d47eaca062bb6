"""Placeholder behaviour modules: configured from YAML, no code needed.

A placeholder serves one state: it may say a sentence, stays in control for a
while (or until preempted when no duration is given) and then succeeds. The
demo modules and the thesis's joke/weather/selfie/follower/Simon-says states
are placeholders; a student replaces one with a real module by starting a node
that offers the same action server. Registered as the module kind ``placeholder``.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass

from cyborg.modules.behaviour import BehaviourModule, GoalContext
from cyborg.modules.kind import BuildContext, KindSettings, ModuleKind, setting
from cyborg.transport.base import Node


@dataclass(frozen=True)
class PlaceholderSpec:
    """What a placeholder does when its state becomes active."""

    action: str
    say: str = ""
    duration: float | None = None
    emotion: tuple[float, float, float] | None = None
    honour_cancel: bool = True


class PlaceholderModule(BehaviourModule):
    """Serves one or more placeholder states from one node."""

    def __init__(self, node: Node, specs: list[PlaceholderSpec]) -> None:
        super().__init__(node)
        self.specs = {spec.action: spec for spec in specs}
        for spec in specs:
            self.serve(spec.action, self._make_execute(spec), honour_cancel=spec.honour_cancel)

    def _make_execute(self, spec: PlaceholderSpec) -> Callable[[GoalContext], Awaitable[None]]:
        async def execute(ctx: GoalContext) -> None:
            if spec.emotion is not None:
                self.send_emotion(*spec.emotion)
            if spec.say:
                self.say(spec.say)
            if spec.duration is None:
                await ctx.wait_forever()
            else:
                await ctx.sleep(spec.duration)

        return execute


@dataclass(frozen=True, kw_only=True)
class PlaceholderServer(KindSettings):
    """One state a placeholder serves."""

    action: str = setting(description="action server of the state")
    say: str = setting("", description="sentence said when the state starts")
    duration: float | None = setting(
        None, ge=0, description="seconds in control before succeeding (none: until preempted)"
    )
    emotion: tuple[float, float, float] | None = setting(
        None, description="PAD change sent when the state starts"
    )
    honour_cancel: bool = setting(
        True, description="false: ignore the controller's cancel (to test its timeout)"
    )


@dataclass(frozen=True, kw_only=True)
class PlaceholderSettings(KindSettings):
    """Serves states from YAML alone: say a sentence, stay a while, succeed (no code needed)."""

    servers: list[PlaceholderServer] = setting(  # noqa: RUF009 (a dataclasses.field)
        min_length=1, description="the states it serves, one entry each"
    )

    def speaks_in(self) -> tuple[str, ...]:
        return tuple(server.action for server in self.servers if server.say)

    def serves(self) -> tuple[str, ...]:
        return tuple(server.action for server in self.servers)


def _build(node: Node, settings: PlaceholderSettings, context: BuildContext) -> PlaceholderModule:
    return PlaceholderModule(
        node,
        [
            PlaceholderSpec(
                action=server.action,
                say=server.say,
                duration=server.duration,
                emotion=server.emotion,
                honour_cancel=server.honour_cancel,
            )
            for server in settings.servers
        ],
    )


KIND = ModuleKind(PlaceholderSettings, _build)
