"""The flight recorder: every run written to MCAP as it happens, in segments under a disk budget.

A :class:`Recorder` listens to a run's :class:`~cyborg.observe.records.RecordStream` (state
changes, emotions, decisions, speech, poses) and, on its own node, to what comes into the robot
(events with their sender, texts heard, emotion commands), to gatekeeper passes and drops and
module crashes, to the controller node's counters (over ROS), to the "mark" notes of the
dashboard, and to the package's warnings and errors. Each goes to the MCAP file with its time on the robot's clock in integer nanoseconds
(:mod:`~cyborg.observe.channels` says where). Every segment holds the run's configuration,
script, seed, version and clock kind (attachments and metadata), the map and the places.

A segment ends after ``segment_seconds`` of robot time or ``segment_bytes`` of file; the oldest
recordings in the folder are deleted while it holds more than ``budget_bytes``. A recorder that
cannot write (a full disk) stops recording, logs why and the fix, and says so on
:data:`~cyborg.observe.channels.RECORDER_STATUS_TOPIC` (the dashboard shows it): the robot runs
on.
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import threading
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from enum import Enum
from pathlib import Path
from typing import IO, Any

import foxglove
from foxglove.channels import GridChannel, LogChannel, SceneUpdateChannel
from foxglove.mcap import MCAPCompression, MCAPWriteOptions, MCAPWriter
from foxglove.messages import (
    Color,
    Grid,
    Log,
    LogLevel,
    PackedElementField,
    PackedElementFieldNumericType,
    Pose,
    Quaternion,
    SceneEntity,
    SceneUpdate,
    SpherePrimitive,
    TextPrimitive,
    Timestamp,
    Vector2,
    Vector3,
)

from cyborg.errors import InvalidValueError
from cyborg.maps import OccupancyMap
from cyborg.observe import channels as ch
from cyborg.observe.records import Record, RecordStream, to_ns
from cyborg.transport import topics
from cyborg.transport.base import MessageInfo, Node
from cyborg.transport.messages import EmotionalFeedback, String

__all__ = [
    "DEFAULT_BUDGET_BYTES",
    "Recorder",
    "RecorderSettings",
    "RecorderState",
    "RunFacts",
    "segment_name",
]

log = logging.getLogger(__name__)


def _compact_json() -> Callable[[Any], str]:
    """Compact JSON (no spaces: smaller files; what it decodes to is the same), by the standard
    library's C encoder made once, not once a message as ``JSONEncoder.encode`` makes it (a
    third of a record's encoding time)."""
    encoder = json.JSONEncoder(separators=(",", ":"), check_circular=False)
    make = getattr(json.encoder, "c_make_encoder", None)
    if make is None:  # an interpreter without the C accelerator
        return encoder.encode
    made = make(
        None, encoder.default, json.encoder.encode_basestring_ascii, None, ":", ",", False, False, True
    )
    return lambda value: "".join(made(value, 0))


_encode = _compact_json()

HOLD_RECORDS = 512
"""Records held before they are written together (see :meth:`Recorder.on_record`)."""
HOLD_NS = 60 * 1_000_000_000
"""Robot time a record is held at most before it is written (the MCAP writer holds a chunk of
64 KiB, about 20 minutes of a robot day, until :meth:`Recorder.flush` anyway)."""

DEFAULT_BUDGET_BYTES = 1024**3
"""1 GiB: about 5 MB a robot day (docs/benchmarks.md), so months of recordings."""
DEFAULT_SEGMENT_SECONDS = 3600.0
DEFAULT_SEGMENT_BYTES = 16 * 1024**2
CHUNK_BYTES = 64 * 1024
"""Small chunks make a seek cheap (a 60 s window read in about a millisecond)."""
PREFIX = "cyborg-"

INPUT_TOPICS: list[tuple[str, type[Any]]] = [
    (topics.TEXT_FROM_SPEECH, String),
    (topics.REGISTER_EVENT, String),
    (topics.SET_EMOTIONAL_STATE, String),
    (topics.SET_EMOTIONAL_VALUES, EmotionalFeedback),
    (topics.EMOTIONAL_CONTROLLER, String),
]


_LOG_LEVELS = {"warning": LogLevel.Warning, "error": LogLevel.Error, "fatal": LogLevel.Fatal}


class RecorderState(Enum):
    RECORDING = "recording"
    FAILED = "failed"
    CLOSED = "closed"


@dataclass(frozen=True)
class RecorderSettings:
    """Where and how much to record.

    ``file``: one named file (``--record FILE.mcap``: no segments, no budget). Otherwise segments
    ``cyborg-<start>-<n>.mcap`` in ``folder``, each at most ``segment_seconds`` of robot time and
    about ``segment_bytes``, the oldest deleted while the folder holds more than ``budget_bytes``.
    """

    folder: Path | None = None
    file: Path | None = None
    budget_bytes: int = DEFAULT_BUDGET_BYTES
    segment_seconds: float = DEFAULT_SEGMENT_SECONDS
    segment_bytes: int = DEFAULT_SEGMENT_BYTES


@dataclass
class RunFacts:
    """What a recording says about its run (metadata and attachments of every segment)."""

    start_ns: int
    """The robot's clock (Unix nanoseconds) when the run's records start (``t_ns`` = 0)."""
    clock: str
    """``virtual`` (as fast as possible), ``virtual xN`` or ``real``."""
    seed: int | None = None
    config_name: str = ""
    config_text: str = ""
    script_name: str = ""
    script_text: str = ""
    extra: dict[str, str] = field(default_factory=dict)

    def metadata(self) -> dict[str, str]:
        from cyborg import __version__

        return {
            "format": ch.FORMAT,
            "format_version": ch.FORMAT_VERSION,
            "version": __version__,
            "start_ns": str(self.start_ns),
            "start": datetime.fromtimestamp(self.start_ns / 1e9, tz=UTC).isoformat(),
            "clock": self.clock,
            "seed": "" if self.seed is None else str(self.seed),
            "config": self.config_name,
            "script": self.script_name,
            **self.extra,
        }


def segment_name(start_ns: int, number: int) -> str:
    stamp = datetime.fromtimestamp(start_ns / 1e9, tz=UTC).strftime("%Y%m%dT%H%M%SZ")
    return f"{PREFIX}{stamp}-{number:04d}.mcap"


class _Sink(io.RawIOBase):
    """The segment's file, as the MCAP writer sees it: notes the first failed write (a full disk)."""

    def __init__(self, file: IO[bytes]) -> None:
        super().__init__()
        self.file = file
        self.failure: OSError | None = None
        self.written = 0

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        try:
            count = self.file.write(data)
        except OSError as exc:
            if self.failure is None:
                self.failure = exc
            raise
        self.written += count
        return count

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        return self.file.seek(offset, whence)

    def tell(self) -> int:
        return self.file.tell()

    def flush(self) -> None:
        try:
            self.file.flush()
        except OSError as exc:
            if self.failure is None:
                self.failure = exc
            raise


class _LogHandler(logging.Handler):
    """The package's warnings and errors, into the recording as foxglove.Log."""

    def __init__(self, recorder: Recorder) -> None:
        super().__init__(level=logging.WARNING)
        self.recorder = recorder

    def emit(self, record: logging.LogRecord) -> None:
        if record.name.startswith(__name__):
            return  # the recorder's own trouble is told on its status topic
        with contextlib.suppress(Exception):
            level = LogLevel.Error if record.levelno >= logging.ERROR else LogLevel.Warning
            self.recorder.log_text(record.getMessage(), record.name, level)


class Recorder:
    """Writes one run to MCAP; see the module docstring. Never raises into the robot."""

    def __init__(
        self,
        node: Node,
        stream: RecordStream,
        settings: RecorderSettings,
        facts: RunFacts,
        *,
        occupancy: OccupancyMap | None = None,
    ) -> None:
        if settings.file is None and settings.folder is None:
            raise InvalidValueError("RecorderSettings needs a folder or a file; fix: give folder= or file=")
        self.node = node
        self.stream = stream
        self.settings = settings
        self.facts = facts
        self.occupancy = occupancy
        self.state = RecorderState.RECORDING
        self.problem: str | None = None
        self.files: list[Path] = []
        """The segments this recorder wrote, oldest first."""
        self.messages = 0
        self._context = foxglove.Context()
        self._json: dict[str, foxglove.Channel] = {}
        for kind, topic in ch.RECORD_TOPICS.items():
            schema = ch.json_schema(ch.SCHEMA_NAMES[kind], ch.RECORD_SCHEMAS[kind])
            self._json[topic] = self._channel(topic, ch.SCHEMA_NAMES[kind], schema)
        for topic, (name, properties) in ch.OTHER_SCHEMAS.items():
            self._json[topic] = self._channel(topic, name, ch.json_schema(name, properties))
        self._log = LogChannel(ch.LOG_TOPIC, context=self._context)
        self._map = GridChannel(ch.MAP_TOPIC, context=self._context)
        self._places = SceneUpdateChannel(ch.PLACES_TOPIC, context=self._context)
        self._writer: MCAPWriter | None = None
        self._held: list[Record] = []
        self._owner = threading.get_ident()  # the thread of the robot's loop: the one that holds records
        self._sink: _Sink | None = None
        self._file: IO[bytes] | None = None
        self._segment_start_ns = 0
        self._number = 0
        self._status = node.publisher(ch.RECORDER_STATUS_TOPIC, String, latch=True)
        self._handler = _LogHandler(self)
        try:
            self._open_segment(self.now_ns())
        except OSError as exc:
            self._fail(exc)
        for topic, message_type in INPUT_TOPICS:
            node.subscribe(topic, message_type, self._input_callback(topic), queue_size=1000)
        node.subscribe(topics.GATEKEEPER_DROPPED, String, self._on_dropped, queue_size=1000)
        node.subscribe(topics.GATEKEEPER_PASSED, String, self._on_passed, queue_size=1000)
        node.subscribe(topics.CONTROLLER_STATS, String, self._on_controller_stats, queue_size=100)
        node.subscribe(topics.MODULE_CRASHED, String, self._on_crashed, queue_size=100)
        node.subscribe(topics.RESOURCE_MUTES, String, self._on_muted, queue_size=100)
        node.subscribe(ch.MARK_TOPIC, String, self._on_mark, queue_size=100)
        node.subscribe(ch.FLUSH_TOPIC, String, self._on_flush, queue_size=10)
        stream.listeners.append(self.on_record)
        if self.state is RecorderState.RECORDING:
            logging.getLogger("cyborg").addHandler(self._handler)

    def _channel(self, topic: str, name: str, schema: dict[str, Any]) -> foxglove.Channel:
        return foxglove.Channel(
            topic,
            message_encoding="json",
            schema=foxglove.Schema(name=name, encoding="jsonschema", data=json.dumps(schema).encode()),
            context=self._context,
        )

    # --- time -----------------------------------------------------------------------------

    def now_ns(self) -> int:
        """Nanoseconds since the run started (the record stream's time line)."""
        return self.stream.now_ns()

    def _log_time(self, t_ns: int) -> int:
        return self.facts.start_ns + t_ns

    def _stamp(self, t_ns: int) -> Timestamp:
        sec, nsec = divmod(self._log_time(t_ns), 1_000_000_000)
        return Timestamp(sec=sec, nsec=nsec)

    # --- segments -------------------------------------------------------------------------

    @property
    def path(self) -> Path | None:
        """The segment being written (None once stopped)."""
        return self.files[-1] if self.files and self._writer is not None else None

    def _open_segment(self, t_ns: int) -> None:
        settings = self.settings
        if settings.file is not None:
            path = settings.file
            path.parent.mkdir(parents=True, exist_ok=True)
        else:
            assert settings.folder is not None
            settings.folder.mkdir(parents=True, exist_ok=True)
            self._number += 1
            path = settings.folder / segment_name(self._log_time(0), self._number)
        self._file = path.open("wb")
        self._sink = _Sink(self._file)
        self.files.append(path)
        self._segment_start_ns = t_ns
        self._writer = foxglove.open_mcap(
            self._sink,
            context=self._context,
            writer_options=MCAPWriteOptions(
                compression=MCAPCompression.Zstd,
                chunk_size=CHUNK_BYTES,
                compression_threads=0,
                profile=ch.PROFILE,
            ),
        )
        try:
            self._writer.write_metadata(ch.METADATA_NAME, self.facts.metadata())
            now = self._log_time(t_ns)
            for name, text, media in (
                (self.facts.config_name or "config.yaml", self.facts.config_text, "application/yaml"),
                (self.facts.script_name or "script.yaml", self.facts.script_text, "application/yaml"),
            ):
                if text:
                    self._writer.attach(
                        log_time=now, create_time=now, name=name, media_type=media, data=text.encode()
                    )
            self._write_scene(t_ns)
        except RuntimeError as exc:
            raise self._sink.failure or OSError(str(exc)) from exc
        self._publish_status()
        if settings.file is None:
            self._keep_budget()

    def _close_segment(self) -> None:
        writer, self._writer = self._writer, None
        file, self._file = self._file, None
        try:
            if writer is not None:
                writer.close()
        finally:
            if file is not None:
                file.close()

    def _rotate_if_due(self, t_ns: int) -> None:
        settings = self.settings
        if settings.file is not None or self._sink is None:
            return
        too_long = t_ns - self._segment_start_ns >= settings.segment_seconds * 1e9
        if too_long or self._sink.written >= settings.segment_bytes:
            self._close_segment()
            self._open_segment(t_ns)

    def _keep_budget(self) -> None:
        """Delete the oldest recordings in the folder while it holds more than the budget."""
        folder = self.settings.folder
        assert folder is not None
        found = sorted(folder.glob(f"{PREFIX}*.mcap"), key=lambda p: (p.stat().st_mtime, p.name))
        sizes = {p: p.stat().st_size for p in found}
        total = sum(sizes.values())
        current = self.files[-1] if self.files else None
        for old in found:
            if total <= self.settings.budget_bytes:
                break
            if old == current:
                continue
            with contextlib.suppress(OSError):
                old.unlink()
                total -= sizes[old]
                log.info("recording %s deleted: the recordings are over their budget", old.name)

    # --- writing --------------------------------------------------------------------------

    def _write(self, topic: str, payload: Mapping[str, Any] | list[Any], t_ns: int) -> None:
        if self._writer is None:
            return
        try:
            self._rotate_if_due(t_ns)
            self._json[topic].log(_encode(payload).encode(), log_time=self.facts.start_ns + t_ns)
            self.messages += 1
            if self._sink is not None and self._sink.failure is not None:
                raise self._sink.failure
        except (OSError, RuntimeError) as exc:
            self._fail(exc)

    def _check(self) -> None:
        if self._sink is not None and self._sink.failure is not None:
            raise self._sink.failure

    def on_record(self, record: Record) -> None:
        """A transcript record: held, then written with the others held (see :meth:`_release`).

        Written one at a time, each record's encoding ran between the robot's other work, with
        the recorder's code and data out of the processor's caches: about three times its cost in
        a loop of records. Held records keep their exact times (MCAP log times); what reads the
        file sees them once :meth:`flush` or :meth:`close` is called, as with the chunk the MCAP
        writer holds back.
        """
        if self._writer is None:
            return
        held = self._held
        held.append(record)
        if len(held) >= HOLD_RECORDS or record["t_ns"] - held[0]["t_ns"] >= HOLD_NS:
            self._release()

    def _release(self) -> None:
        """Write the records held, in their order (before anything else is written)."""
        held, self._held = self._held, []
        for record in held:
            if self._writer is None:
                return
            self._write_record(record)

    def _write_record(self, record: Record) -> None:
        """A transcript record: to its JSON channel (and the Foxglove views of it)."""
        kind = str(record["type"])
        topic = ch.RECORD_TOPICS.get(kind)
        if topic is None:
            return
        t_ns = int(record["t_ns"])
        fields = record.copy()
        del fields["t"], fields["t_ns"], fields["type"]
        if kind == "pose":
            self._write(topic, ch.pose_message(fields, self._log_time(t_ns)), t_ns)
            return
        self._write(topic, fields, t_ns)
        try:
            if kind in ("say", "heard"):
                who = "robot" if kind == "say" else "user"
                self._log_entry(f"{who}: {fields['text']}", "speech", LogLevel.Info, t_ns)
            elif kind == "recognised":
                verdict = "accepted" if fields.get("accepted") else "rejected"
                text = f"recognised {fields['text']!r} ({verdict}, confidence {fields['confidence']})"
                self._log_entry(text, "speech", LogLevel.Info, t_ns)
            elif kind == "state":
                text = f"{fields['from'] or '-'} --{fields['event']}--> {fields['to']}"
                self._log_entry(text, "controller", LogLevel.Info, t_ns)
            elif kind == "problems":
                for problem in fields["open"]:
                    fix = f"; fix: {problem['fix']}" if problem["fix"] else ""
                    self._log_entry(
                        f"{problem['problem']}{fix}", str(fields["module"]), LogLevel.Warning, t_ns
                    )
        except (OSError, RuntimeError) as exc:
            self._fail(exc)

    def _log_entry(self, text: str, name: str, level: LogLevel, t_ns: int) -> None:
        if self._writer is None:
            return
        self._log.log(
            Log(timestamp=self._stamp(t_ns), level=level, message=text, name=name),
            log_time=self._log_time(t_ns),
        )
        self._check()

    def log_text(self, text: str, name: str, level: LogLevel) -> None:
        """A line for Foxglove's Log panel (warnings and errors of the package)."""
        if threading.get_ident() == self._owner:  # (another thread's warning leaves the held records be)
            self._release()
        try:
            self._log_entry(text, name, level, self.now_ns())
        except (OSError, RuntimeError) as exc:
            self._fail(exc)

    def mark(self, note: str) -> None:
        """Put a note into the recording (the dashboard's "mark" button)."""
        t_ns = self.now_ns()
        self._release()
        self._write(ch.MARK_CHANNEL, {"note": note}, t_ns)
        self.log_text(f"mark: {note}", "operator", LogLevel.Info)

    def _input_callback(self, topic: str) -> Any:
        def on_input(message: Any, info: MessageInfo) -> None:
            t_ns = self.now_ns()
            self._release()
            if topic == topics.REGISTER_EVENT:
                event = {"event": message.data, "sender": info.sender, "source": ch.source_of(info.sender)}
                self._write(ch.EVENT_TOPIC, event, t_ns)
            if info.sender in ch.EXTERNAL_SENDERS:
                data: Any = message.data if isinstance(message, String) else _plain(message)
                self._write(ch.INPUT_TOPIC, {"topic": topic, "sender": info.sender, "data": data}, t_ns)

        return on_input

    def _on_dropped(self, message: String, info: MessageInfo) -> None:
        self._diagnostic("dropped", message, info, LogLevel.Warning)

    def _on_passed(self, message: String, info: MessageInfo) -> None:
        self._diagnostic("passed", message, info, None)

    def _on_controller_stats(self, message: String, info: MessageInfo) -> None:
        """The controller node's counters (handovers, preempt timeouts, connect failures...), as
        they change: a launch's health over time (in one process nobody publishes them)."""
        self._diagnostic("controller", message, info, None)

    def _on_muted(self, message: String, info: MessageInfo) -> None:
        """Who is muted in a parallel state, and by whom, as it changes (docs/parallel.md)."""
        self._diagnostic("muted", message, info, None)

    def _on_crashed(self, message: String, info: MessageInfo) -> None:
        self._diagnostic("crashed", message, info, LogLevel.Error)

    def _diagnostic(self, kind: str, message: String, info: MessageInfo, level: LogLevel | None) -> None:
        """A gatekeeper's pass or drop, a module's crash: to the diagnostics channel (and, unless
        ``level`` is None, as a line of Foxglove's Log panel)."""
        try:
            detail: Any = json.loads(message.data)
        except ValueError:
            detail = message.data
        t_ns = self.now_ns()
        self._release()
        self._write(ch.DIAGNOSTIC_TOPIC, {"kind": kind, "sender": info.sender, "detail": detail}, t_ns)
        if level is None:
            return
        try:
            self._log_entry(f"{kind}: {message.data}", info.sender or "diagnostics", level, t_ns)
        except (OSError, RuntimeError) as exc:
            self._fail(exc)

    def node_log(self, *, node: str, level: str, text: str, where: Mapping[str, Any]) -> None:
        """Another node's warning, error or fatal message (heard on ROS's ``/rosout``; see
        :mod:`~cyborg.observe.rosout`): the diagnostics channel (kind ``rosout``, its ``level``,
        ``message``, ``file``, ``function`` and ``line``) and a line of Foxglove's Log panel under
        the node's name."""
        t_ns = self.now_ns()
        self._release()
        detail = {"level": level, "message": text, **where}
        self._write(ch.DIAGNOSTIC_TOPIC, {"kind": "rosout", "sender": node, "detail": detail}, t_ns)
        try:
            self._log_entry(text, node, _LOG_LEVELS.get(level, LogLevel.Warning), t_ns)
        except (OSError, RuntimeError) as exc:
            self._fail(exc)

    def _on_mark(self, message: String, info: MessageInfo) -> None:
        self.mark(message.data.strip()[:500] or "mark")

    def flush(self) -> None:
        """Write out the chunk held back, so that the file can be read up to now."""
        self._release()
        if self._writer is None:
            return
        try:
            self._writer.flush()
            self._check()
        except (OSError, RuntimeError) as exc:
            self._fail(exc)

    def _on_flush(self, message: String, info: MessageInfo) -> None:
        self.flush()
        self._publish_status(flushed=message.data[:100])

    def _write_scene(self, t_ns: int) -> None:
        """The map (foxglove.Grid) and its named places (foxglove.SceneUpdate), once a segment."""
        occupancy = self.occupancy
        if occupancy is None:
            return
        _rows, cols = occupancy.shape
        grid = Grid(
            timestamp=self._stamp(t_ns),
            frame_id=ch.FRAME,
            pose=Pose(
                position=Vector3(x=float(occupancy.origin[0]), y=float(occupancy.origin[1]), z=0.0),
                orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            ),
            column_count=cols,
            cell_size=Vector2(x=occupancy.resolution, y=occupancy.resolution),
            row_stride=cols,
            cell_stride=1,
            fields=[PackedElementField(name="cell", offset=0, type=PackedElementFieldNumericType.Uint8)],
            data=_grid_values(occupancy),
        )
        self._map.log(grid, log_time=self._log_time(t_ns))
        entities = [
            SceneEntity(
                timestamp=self._stamp(t_ns),
                frame_id=ch.FRAME,
                id=place.name,
                spheres=[
                    SpherePrimitive(
                        pose=Pose(
                            position=Vector3(x=place.x, y=place.y, z=0.0),
                            orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
                        ),
                        size=Vector3(x=0.4, y=0.4, z=0.4),
                        color=Color(r=0.2, g=0.5, b=0.9, a=0.8),
                    )
                ],
                texts=[
                    TextPrimitive(
                        pose=Pose(
                            position=Vector3(x=place.x, y=place.y, z=0.5),
                            orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
                        ),
                        billboard=True,
                        font_size=14.0,
                        scale_invariant=True,
                        color=Color(r=1.0, g=1.0, b=1.0, a=1.0),
                        text=place.name,
                    )
                ],
            )
            for place in occupancy.poses
        ]
        self._places.log(SceneUpdate(entities=entities), log_time=self._log_time(t_ns))

    # --- status ---------------------------------------------------------------------------

    def status(self) -> dict[str, Any]:
        """What the dashboard shows: recording where, or stopped and why."""
        return {
            "recording": self.state is RecorderState.RECORDING,
            "state": self.state.value,
            "file": str(self.files[-1]) if self.files else None,
            "files": [str(path) for path in self.files[-2:]],
            "problem": self.problem,
            "messages": self.messages + len(self._held),
        }

    def _publish_status(self, **extra: str) -> None:
        with contextlib.suppress(Exception):
            self._status.publish(String(json.dumps({**self.status(), **extra})))

    def _fail(self, exc: BaseException) -> None:
        if self.state is not RecorderState.RECORDING:
            return
        failure = self._sink.failure if self._sink is not None and self._sink.failure else exc
        reason = failure.strerror if isinstance(failure, OSError) and failure.strerror else str(failure)
        where = self.files[-1] if self.files else (self.settings.file or self.settings.folder)
        self.problem = (
            f"the recorder stopped: cannot write {where}: {reason}; fix: free disk space or lower the "
            "recording budget (recording: budget_mb), or record elsewhere (--record FILE.mcap); "
            "the robot runs on unrecorded"
        )
        self.state = RecorderState.FAILED
        self._held = []
        log.error("%s", self.problem)
        logging.getLogger("cyborg").removeHandler(self._handler)
        with contextlib.suppress(Exception):
            self._close_segment()
        self._writer = None
        self._publish_status()

    def close(self) -> None:
        """Finish the segment (its summary makes it seekable); the recorder then writes nothing."""
        logging.getLogger("cyborg").removeHandler(self._handler)
        self._release()
        if self.state is RecorderState.RECORDING:
            try:
                self._close_segment()
            except (OSError, RuntimeError) as exc:
                self._fail(exc)
                return
            self.state = RecorderState.CLOSED
            if self.settings.file is None:
                self._keep_budget()
            self._publish_status()


def _grid_values(occupancy: OccupancyMap) -> bytes:
    """The grid as foxglove.Grid cells, row 0 at the origin: 0 free, 100 occupied, 255 unknown."""
    from cyborg.maps import Cell

    grid = occupancy.grid
    values = {int(Cell.FREE): 0, int(Cell.OCCUPIED): 100, int(Cell.UNKNOWN): 255}
    import numpy as np

    table = np.full(256, 255, dtype=np.uint8)
    for cell, value in values.items():
        table[cell] = value
    return bytes(table[grid].tobytes())


def _plain(message: Any) -> Any:
    """A message dataclass as plain JSON values."""
    import dataclasses

    if dataclasses.is_dataclass(message) and not isinstance(message, type):
        return dataclasses.asdict(message)
    return str(message)


def now_facts(clock_kind: str, start_epoch_s: float, **kwargs: Any) -> RunFacts:
    """Facts of a run whose records start at ``start_epoch_s`` (the clock's Unix time then)."""
    return RunFacts(start_ns=to_ns(start_epoch_s), clock=clock_kind, **kwargs)
