"""The flight recorder: a scripted run's recording, read by the ``mcap`` library (not our reader),
holds its transcript; bad files get a clear error; a failing disk never stops the robot;
segments rotate and the folder keeps its budget; ``cyborg rerun`` compares decisions."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from mcap.reader import make_reader

from cyborg.app.config import load_config, packaged_config
from cyborg.cli import cli
from cyborg.observe import channels as ch
from cyborg.observe.recorder import RecorderSettings
from cyborg.observe.recording import RecordingError, open_recording
from cyborg.sim.scenario import run_scenario
from cyborg.sim.script import parse_script
from cyborg.sim.transcript import in_transcript_order
from tests.support.paths import SCENARIOS

SCENARIO_D = SCENARIOS / "scenario_d.yaml"


def record_d(tmp_path: Path) -> tuple[Path, Path, str]:
    transcript, recording = tmp_path / "d.jsonl", tmp_path / "d.mcap"
    result = CliRunner().invoke(
        cli,
        [
            "sim",
            "--script",
            str(SCENARIO_D),
            "--speed",
            "max",
            "--transcript",
            str(transcript),
            "--record",
            str(recording),
        ],
    )
    assert result.exit_code == 0, result.output
    assert f"recorded to {recording}" in result.output
    return transcript, recording, result.output


def test_a_scripted_run_s_recording_read_by_the_mcap_library_holds_its_transcript(
    d_run: tuple[Path, Path, str], tmp_path: Path
) -> None:
    transcript, recording, _ = d_run
    expected = [json.loads(line) for line in transcript.read_text().splitlines()]
    with recording.open("rb") as file:
        reader = make_reader(file)
        [meta] = [m for m in reader.iter_metadata() if m.name == "cyborg"]
        start = int(meta.metadata["start_ns"])
        assert meta.metadata["seed"] == "5" and meta.metadata["clock"] == "virtual"
        attachments = {a.name: a.data for a in reader.iter_attachments()}
        assert attachments["scenario_d.yaml"] == SCENARIO_D.read_bytes()
        assert b"motivator:" in attachments["cyborg.yaml"]
        kinds = {topic: kind for kind, topic in ch.RECORD_TOPICS.items()}
        back = []
        schemas = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            schemas[channel.topic] = (schema.name if schema else None, channel.message_encoding)
            if channel.topic in kinds:
                t_ns = message.log_time - start
                fields = json.loads(message.data)
                if kinds[channel.topic] == "pose":  # a foxglove.PoseInFrame, its yaw rounded as recorded
                    pose = fields["pose"]
                    yaw = 2 * math.atan2(pose["orientation"]["z"], pose["orientation"]["w"])
                    assert (
                        fields["timestamp"]["sec"] * 10**9 + fields["timestamp"]["nsec"] == message.log_time
                    )
                    fields = {"x": pose["position"]["x"], "y": pose["position"]["y"], "theta": round(yaw, 3)}
                back.append({"t": round(t_ns / 1e9, 3), "t_ns": t_ns, "type": kinds[channel.topic], **fields})
    assert in_transcript_order(back) == expected  # the transcript orders each instant's records
    assert schemas["/log"] == ("foxglove.Log", "protobuf")
    assert schemas["/robot/pose"] == ("foxglove.PoseInFrame", "json")  # one message a pose
    assert schemas["/map"] == ("foxglove.Grid", "protobuf")
    assert schemas["/places"] == ("foxglove.SceneUpdate", "protobuf")
    assert schemas["/cyborg_controller/state_change"] == ("cyborg.StateChange", "json")
    read = open_recording(recording)
    events = read.events
    assert {"event": "start", "sender": "cyborg_controller", "source": "module"} not in events
    passed = [entry for entry in read.logs if entry["kind"] == "passed"]
    said = [r["text"] for r in expected if r["type"] == "say"]
    assert passed and passed[0]["detail"]["gatekeeper"] == "cyborg_speech_gatekeeper"
    assert [entry["detail"]["message"] for entry in passed] == said, "each sentence said passed a gatekeeper"
    assert any(e["source"] == "motivator" for e in events), "the motivator's events carry their source"


def test_rerun_says_where_another_configuration_decides_otherwise(
    d_run: tuple[Path, Path, str], tmp_path: Path
) -> None:
    _, recording, _ = d_run
    same = CliRunner().invoke(cli, ["rerun", str(recording), "--transcript", str(tmp_path / "again.jsonl")])
    assert same.exit_code == 0, same.output
    assert "same decisions as recorded" in same.output
    assert (tmp_path / "again.jsonl").read_text() == (tmp_path / "d.jsonl").read_text()
    other = tmp_path / "calm.yaml"
    text = packaged_config("cyborg.yaml").read_text()
    other.write_text(text.replace("rate_seconds: 2", "rate_seconds: 7"))
    what_if = CliRunner().invoke(cli, ["rerun", str(recording), "--config", str(other)])
    assert what_if.exit_code == 1, what_if.output
    assert "the decisions first differ at decision" in what_if.output
    assert f"with {other}" in what_if.output


def test_bad_recordings_get_errors_that_name_the_fix(d_run: tuple[Path, Path, str], tmp_path: Path) -> None:
    _, recording, _ = d_run
    text_file = tmp_path / "notes.mcap"
    text_file.write_text("hello")
    with pytest.raises(RecordingError, match=r"is not an MCAP file.*fix:"):
        open_recording(text_file)
    foreign = tmp_path / "foreign.mcap"
    from mcap.writer import Writer

    with foreign.open("wb") as file:
        writer = Writer(file)
        writer.start()
        schema = writer.register_schema("x", "jsonschema", b"{}")
        channel = writer.register_channel("/x", "json", schema)
        writer.add_message(channel, 1, b"{}", 1)
        writer.finish()  # type: ignore[no-untyped-call]
    with pytest.raises(RecordingError, match=r"not one this robot recorded.*Foxglove"):
        open_recording(foreign)
    result = CliRunner().invoke(cli, ["rerun", str(foreign)])
    assert result.exit_code == 1 and "not one this robot recorded" in result.output
    data = recording.read_bytes()
    newer = tmp_path / "newer.mcap"
    newer.write_bytes(data.replace(b"format_version\x01\x00\x00\x002", b"format_version\x01\x00\x00\x009"))
    with pytest.raises(RecordingError, match="recording format 9; this cyborg reads formats 1, 2; fix"):
        open_recording(newer)
    cut = tmp_path / "cut.mcap"
    longer = tmp_path / "longer.mcap"
    script = parse_script("seed: 1\nuntil: 1500\n")
    run_scenario(load_config(packaged_config("cyborg.yaml")), script, record=RecorderSettings(file=longer))
    with longer.open("rb") as file:
        summary = make_reader(file).get_summary()
    assert summary is not None and len(summary.chunk_indexes) > 2
    middle = sorted(c.chunk_start_offset for c in summary.chunk_indexes)[-2]
    cut.write_bytes(longer.read_bytes()[: middle + 20])  # into a chunk: the robot lost power there
    partial = open_recording(cut)
    assert partial.problem is not None and "cut short" in partial.problem
    full = open_recording(longer)
    assert 0 < len(partial.records) < len(full.records)
    assert partial.records == full.records[: len(partial.records)], "what is read of a cut file is right"


def test_a_full_disk_stops_the_recorder_and_not_the_robot(tmp_path: Path) -> None:
    transcript = tmp_path / "d.jsonl"
    result = CliRunner().invoke(
        cli,
        [
            "sim",
            "--script",
            str(SCENARIO_D),
            "--speed",
            "max",
            "--transcript",
            str(transcript),
            "--record",
            "/dev/full",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "2 of 2 expectations met" in result.output, "the robot ran its script to the end"
    assert len(transcript.read_text().splitlines()) > 100


def test_segments_rotate_by_robot_time_and_the_folder_keeps_its_budget(tmp_path: Path) -> None:
    folder = tmp_path / "recordings"
    folder.mkdir()
    old = folder / "cyborg-20250101T000000Z-0001.mcap"
    old.write_bytes(b"x" * 3_000_000)
    script = parse_script("seed: 1\nuntil: 1000\n")
    settings = RecorderSettings(folder=folder, budget_bytes=2_500_000, segment_seconds=300)
    records = run_scenario(load_config(packaged_config("cyborg.yaml")), script, record=settings)
    segments = sorted(folder.glob("cyborg-*.mcap"))
    assert not old.exists(), "the oldest recording went to keep the budget"
    assert len(segments) == 4, segments  # 0-300, 300-600, 600-900, 900-1000 s
    assert sum(p.stat().st_size for p in segments) < 2_500_000
    back = [r for p in segments for r in open_recording(p).records]
    assert back == list(records), "every record is in one segment, in order"
    assert all(open_recording(p).attachments for p in segments), "each segment carries the configuration"


def test_problems_mutes_and_other_nodes_warnings_are_recorded_for_the_mcap_reader(tmp_path: Path) -> None:
    """A module's problem (with its fix), the modules muted in a parallel state and other nodes'
    warnings and errors (ROS 1's /rosout_agg, in one process here) reach the file."""
    import json as _json

    from cyborg.modules import ProblemReporter
    from cyborg.observe.recorder import Recorder, RunFacts
    from cyborg.observe.records import RecordStream
    from cyborg.observe.rosout import Ros1Log, hear_ros_logs
    from cyborg.transport import topics
    from cyborg.transport.clock import VirtualClock
    from cyborg.transport.embedded import EmbeddedTransport
    from cyborg.transport.messages import String

    clock = VirtualClock()
    transport = EmbeddedTransport(clock)
    file = tmp_path / "run.mcap"
    node = transport.node("cyborg_recorder")
    recorder = Recorder(
        node, RecordStream(node), RecorderSettings(file=file), RunFacts(start_ns=0, clock="virtual")
    )
    tts = ProblemReporter(transport.node("cyborg_tts"))
    mutes = transport.node("cyborg_controller").publisher(topics.RESOURCE_MUTES, String)
    assert hear_ros_logs(recorder, "ROS 1") is not None
    rosout = transport.node("rosout").publisher("/rosout_agg", Ros1Log)

    async def main() -> None:
        tts.report("the robot cannot speak aloud: no sound device", "plug in the speaker", key="sound")
        mutes.publish(
            String(_json.dumps({"states": ["music", "battery_warning"], "muted": [{"resource": "speaker"}]}))
        )
        for level, name, text in [
            (4, "/camera_driver", "lens dirty"),
            (2, "/camera_driver", "frame 12"),  # information: left out
            (8, "/cyborg_recorder", "the recorder's own"),  # told by its logging handler instead
            (16, "/base_driver", "motor controller lost"),
        ]:
            rosout.publish(Ros1Log(level=level, name=name, msg=text, file="driver.py", line=7))
        await clock.sleep(1.0)

    clock.run(main())
    recorder.close()
    transport.shutdown()
    clock.close()
    seen: dict[str, list[dict[str, object]]] = {}
    with file.open("rb") as opened:
        for _schema, channel, message in make_reader(opened).iter_messages():
            if channel.topic in ("/cyborg/problems", "/cyborg/diagnostics", "/log"):
                seen.setdefault(channel.topic, []).append(
                    _json.loads(message.data) if channel.topic != "/log" else {}
                )
    [problems] = seen["/cyborg/problems"]
    assert problems["module"] == "cyborg_tts"
    assert problems["open"] == [
        {
            "key": "sound",
            "problem": "the robot cannot speak aloud: no sound device",
            "fix": "plug in the speaker",
        }
    ]
    logs = [(d["sender"], d["detail"]) for d in seen["/cyborg/diagnostics"] if d["kind"] == "rosout"]
    assert logs == [
        (
            "camera_driver",
            {"level": "warning", "message": "lens dirty", "file": "driver.py", "function": "", "line": 7},
        ),
        (
            "base_driver",
            {
                "level": "fatal",
                "message": "motor controller lost",
                "file": "driver.py",
                "function": "",
                "line": 7,
            },
        ),
    ], "other nodes' warnings and errors, not their information nor the recorder's own"
    assert [(e["level"], e["sender"]) for e in open_recording(file).logs if e["kind"] == "rosout"] == [
        ("warning", "camera_driver"),
        ("fatal", "base_driver"),
    ]
    [muted] = [d for d in seen["/cyborg/diagnostics"] if d["kind"] == "muted"]
    assert muted["sender"] == "cyborg_controller" and muted["detail"]["muted"] == [{"resource": "speaker"}]  # type: ignore[index]


def test_the_controller_alone_re_runs_against_the_recorded_events_and_module_outcomes(
    d_run: tuple[Path, Path, str],
) -> None:
    """What `cyborg rerun` does with a launch's real-time recording (tests/ros/test_quiet_stop.py
    runs it on one made over ROS 1), here on scenario D's: the controller alone, fed the recorded
    events and module outcomes at their times, makes the recorded state changes at the recorded
    nanoseconds; a machine without one transition parts from the recording where it is used."""
    from cyborg.app.config import parse_config
    from cyborg.sim.rerun_controller import first_state_difference, rerun_controller

    _, recording, _ = d_run
    read = open_recording(recording)
    recorded = [r for r in read.records if r["type"] == "state"]
    text = packaged_config("cyborg.yaml").read_text()
    result = rerun_controller(read, parse_config(text).machine)
    assert result.events >= 10 and result.outcomes >= 10, result.inputs
    assert result.changes == recorded
    assert first_state_difference(recorded, result.changes) is None
    calmer = text.replace("      conversation_interest: conversation\n", "", 1)
    other = rerun_controller(read, parse_config(calmer).machine)
    difference = first_state_difference(recorded, other.changes)
    assert difference is not None and difference.index == 1, difference
    assert difference.recorded is not None and difference.recorded["to"] == "conversation"
    assert "state change 2: recorded t=9 s" in difference.describe(noun="state change")


def test_an_event_recorded_just_after_the_state_change_it_caused_is_still_its_cause() -> None:
    """Over ROS the recorder hears the sender and the controller on two connections: under load
    the state change on "aborted" can be recorded before the event "aborted" that caused it. The
    re-run must send that event (once, before the change), not also end the module's goal."""
    from types import SimpleNamespace

    from cyborg.sim.rerun_controller import controller_inputs

    ms = 1_000_000
    recording: Any = SimpleNamespace(
        events=[{"t_ns": 5_030 * ms, "event": "aborted"}, {"t_ns": 9_000 * ms, "event": "ignored"}],
        records=[
            {"type": "state", "t_ns": 200 * ms, "event": "start", "from": "", "to": "idle"},
            {"type": "state", "t_ns": 5_000 * ms, "event": "aborted", "from": "idle", "to": "idle"},
            {"type": "state", "t_ns": 8_000 * ms, "event": "succeeded", "from": "idle", "to": "idle"},
        ],
    )
    inputs = controller_inputs(recording)
    assert [(i.kind, i.name, i.t_ns) for i in inputs] == [
        ("event", "aborted", 5_000 * ms),
        ("outcome", "succeeded", 8_000 * ms),
        ("event", "ignored", 9_000 * ms),
    ]
