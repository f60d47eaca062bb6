"""Re-run a recorded run from its recorded inputs, and compare what the robot did.

A recording holds everything that came into the robot from outside (what it heard, the events
and emotion commands of a script or an operator) at its exact time in integer nanoseconds, plus
the configuration, the script's start, seed, calendar and end. :func:`rerun` builds a fresh
robot on a virtual clock from those and plays the inputs again at their times, as ``at`` steps
of the same script driver: the same run gives the same transcript, byte for byte. With another
configuration (a what-if), :func:`first_difference` says where the decisions first part.
"""

from __future__ import annotations

import io
import json
import logging
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from cyborg.app.config import LoadedConfig, parse_config
from cyborg.errors import CyborgError
from cyborg.observe.recorder import RecorderSettings
from cyborg.observe.recording import Input, Recording
from cyborg.observe.records import NS_PER_S, Record
from cyborg.sim.scenario import run_scenario
from cyborg.sim.script import Script, Step, parse_script
from cyborg.transport import topics

__all__ = ["Difference", "RerunResult", "first_difference", "inputs_script", "rerun"]

log = logging.getLogger(__name__)

STEP_OF_TOPIC = {
    topics.TEXT_FROM_SPEECH: "say",
    topics.REGISTER_EVENT: "event",
    topics.SET_EMOTIONAL_STATE: "emotion",
}
"""Recorded input topic -> the script step that publishes it again."""
DECISIONS = ("state", "motivator")
"""The record types that are the robot's decisions."""


@dataclass
class RerunResult:
    records: list[Record]
    transcript: str
    """The re-run's transcript (JSON lines), as ``--transcript`` writes it."""
    skipped: list[str]
    """Recorded inputs a re-run cannot play (said why)."""


@dataclass(frozen=True)
class Difference:
    index: int
    recorded: Record | None
    rerun: Record | None

    def describe(self, what: str = "the re-run", noun: str = "decision") -> str:
        def brief(record: Record | None) -> str:
            if record is None:
                return "nothing (the run had ended)"
            fields = {k: v for k, v in record.items() if k not in ("t", "t_ns")}
            return f"t={record['t']:g} s {json.dumps(fields)}"

        return f"{noun} {self.index + 1}: recorded {brief(self.recorded)}; {what}: {brief(self.rerun)}"


def inputs_script(recording: Recording) -> tuple[Script, list[str]]:
    """The script that plays the recording's inputs again at their times (with its start, seed,
    emotion, calendar and end), and the inputs it cannot play."""
    text = recording.script_text
    if text is not None:
        base = parse_script(text, source=recording.metadata.get("script") or "<recorded script>")
    else:
        start = datetime.fromtimestamp(recording.start_ns / NS_PER_S, tz=UTC)
        until = recording.end_ns / NS_PER_S + 1.0
        base = Script(start=start, seed=recording.seed or 0, until=until, steps=[])
    steps: list[Step] = []
    skipped: list[str] = []
    for each in recording.inputs:
        action = STEP_OF_TOPIC.get(each.topic)
        if action is None or not isinstance(each.data, str):
            skipped.append(_skipped(each))
            continue
        steps.append(Step.model_validate({"at": each.t_ns / NS_PER_S, action: each.data}))
    script = base.model_copy(update={"steps": steps})
    script.source = base.source
    return script, skipped


def _skipped(each: Input) -> str:
    return f"t={each.t_ns / NS_PER_S:g} s {each.topic} from {each.sender}: a re-run cannot play it yet"


def recorded_config(recording: Recording) -> LoadedConfig:
    text = recording.config_text
    if text is None:
        raise CyborgError(
            f"{recording.path} holds no configuration (attachment {recording.metadata.get('config')!r}); "
            "fix: give one with --config FILE.yaml"
        )
    return parse_config(text, source=f"{recording.path}:{recording.metadata.get('config')}")


def rerun(
    recording: Recording,
    *,
    config: LoadedConfig | None = None,
    record: RecorderSettings | None = None,
) -> RerunResult:
    """Run a fresh robot (the recorded configuration unless ``config``) on the recorded inputs."""
    if recording.metadata.get("clock", "virtual").startswith("real"):
        log.warning(
            "%s was recorded in real time: the re-run plays its inputs in virtual time, so modules "
            "that wait on real time may differ",
            recording.path,
        )
    script, skipped = inputs_script(recording)
    out = io.StringIO()
    records = run_scenario(
        config or recorded_config(recording), script, transcript=out, keep_records=True, record=record
    )
    return RerunResult(list(records), out.getvalue(), skipped)


def first_difference(recorded: list[Record], rerun: list[Record]) -> Difference | None:
    """Where the decisions (state changes, motivator decisions) of two runs first differ."""
    mine = [r for r in recorded if r["type"] in DECISIONS]
    theirs = [r for r in rerun if r["type"] in DECISIONS]
    for index in range(max(len(mine), len(theirs))):
        a = mine[index] if index < len(mine) else None
        b = theirs[index] if index < len(theirs) else None
        if a != b:
            return Difference(index, a, b)
    return None


def transcript_of(records: list[Record]) -> str:
    """Records as the transcript file has them (one JSON object a line)."""
    return "".join(json.dumps(record) + "\n" for record in records)


def write_transcript(path: Path, text: str) -> None:
    try:
        path.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise CyborgError(
            f"cannot write the transcript {path}: {exc.strerror}; fix: give a writable path"
        ) from exc
