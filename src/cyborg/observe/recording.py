"""Read a recording back: its facts, its records, its inputs, any moment of it.

:func:`open_recording` checks that the file is an MCAP written by this project's recorder in a
format version this code reads, and reads it with the ``mcap`` library. A file cut short (the
robot lost power while recording) is read up to the cut, and says so (:attr:`Recording.problem`).
Records come back exactly as the transcript had them (``t_ns`` from the message's log time).
"""

from __future__ import annotations

import bisect
import json
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from cyborg.errors import CyborgError
from cyborg.observe import channels as ch
from cyborg.observe.records import Record, readable_seconds

if TYPE_CHECKING:
    from cyborg.maps import OccupancyMap

__all__ = ["Glance", "Input", "Recording", "RecordingError", "glance", "open_recording", "recorded_map"]

MAGIC = b"\x89MCAP0\r\n"


class RecordingError(CyborgError):
    """A file that is no recording this code can read: the message names the problem and the fix."""


@dataclass(frozen=True)
class Input:
    """Something that came into the robot from outside, as recorded."""

    t_ns: int
    topic: str
    sender: str
    data: Any


@dataclass
class Recording:
    """One recording, read whole: its metadata, attachments, records and inputs."""

    path: Path
    metadata: dict[str, str]
    attachments: dict[str, bytes]
    records: list[Record]
    """The transcript's records, in the order they happened."""
    inputs: list[Input]
    events: list[dict[str, Any]] = field(default_factory=list)
    """Every event sent to the controller (``t_ns``, ``event``, ``sender``, ``source``)."""
    marks: list[dict[str, Any]] = field(default_factory=list)
    logs: list[dict[str, Any]] = field(default_factory=list)
    """Gatekeeper passes (level ``info``) and drops, module crashes, the controller node's counters
    (``info``), other nodes' warnings and errors on a ROS graph (``rosout``, level ``warning``,
    ``error`` or ``fatal``): ``t_ns``, ``level``, ``kind`` (passed, dropped, crashed, controller,
    muted, rosout), ``sender``, ``detail``."""
    problem: str | None = None
    """Why the file was read only in part (it was cut short), else None."""
    scene: dict[str, tuple[Schema, bytes]] = field(default_factory=dict, repr=False)
    """The first map (foxglove.Grid) and places (foxglove.SceneUpdate) messages, by topic, undecoded."""
    _times: list[int] = field(default_factory=list, repr=False)

    @property
    def start_ns(self) -> int:
        """Unix nanoseconds of the robot's clock at ``t_ns`` = 0."""
        return int(self.metadata["start_ns"])

    @property
    def end_ns(self) -> int:
        """The last record's ``t_ns`` (0 for an empty recording)."""
        return self.records[-1]["t_ns"] if self.records else 0

    @property
    def seed(self) -> int | None:
        seed = self.metadata.get("seed", "")
        return int(seed) if seed else None

    def attachment_text(self, name: str) -> str | None:
        data = self.attachments.get(name)
        return None if data is None else data.decode("utf-8")

    @property
    def config_text(self) -> str | None:
        return self.attachment_text(self.metadata.get("config", ""))

    @property
    def script_text(self) -> str | None:
        return self.attachment_text(self.metadata.get("script", ""))

    def upto(self, t_ns: int) -> list[Record]:
        """The records up to and including ``t_ns``."""
        if len(self._times) != len(self.records):
            self._times = [int(r["t_ns"]) for r in self.records]
        return self.records[: bisect.bisect_right(self._times, t_ns)]

    def index_upto(self, t_ns: int) -> int:
        """How many records came up to and including ``t_ns``."""
        if len(self._times) != len(self.records):
            self._times = [int(r["t_ns"]) for r in self.records]
        return bisect.bisect_right(self._times, t_ns)


def _check_file(path: Path) -> None:
    if not path.exists():
        raise RecordingError(
            f"{path}: no such file; fix: check the path (recordings are in the data folder's recordings/)"
        )
    if path.is_dir():
        raise RecordingError(f"{path} is a folder; fix: name one .mcap file in it")
    with path.open("rb") as file:
        head = file.read(len(MAGIC))
    if head != MAGIC:
        raise RecordingError(
            f"{path} is not an MCAP file (it starts with {head[:8]!r}); fix: give a recording the robot "
            "wrote (.mcap, e.g. from --record FILE.mcap or the data folder's recordings/)"
        )


def _check_metadata(path: Path, metadata: dict[str, str] | None) -> dict[str, str]:
    if metadata is None or metadata.get("format") != ch.FORMAT:
        raise RecordingError(
            f"{path} is an MCAP file, but not one this robot recorded (it has no '{ch.METADATA_NAME}' "
            "metadata); fix: open it in Foxglove or Lichtblick, or give a recording made by `cyborg`"
        )
    version = metadata.get("format_version")
    if version not in ch.READABLE_VERSIONS:
        raise RecordingError(
            f"{path} was recorded by cyborg {metadata.get('version', '?')} in recording format "
            f"{version}; this cyborg reads formats {', '.join(ch.READABLE_VERSIONS)}; fix: read it with cyborg "
            f"{metadata.get('version', 'of that version')} (pip install cyborg=={metadata.get('version', '?')})"
        )
    if "start_ns" not in metadata:
        raise RecordingError(f"{path}: its metadata lacks start_ns; fix: record it again")
    return metadata


def _read_all(stream: IO[bytes]) -> Iterator[tuple[Schema | None, Channel, Message] | Metadata | Attachment]:
    """Every message, metadata and attachment in file order (works on a file cut short up to the cut)."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    for record in StreamReader(stream, skip_magic=False, validate_crcs=False).records:
        if isinstance(record, Schema):
            schemas[record.id] = record
        elif isinstance(record, Channel):
            channels[record.id] = record
        elif isinstance(record, Message):
            channel = channels[record.channel_id]
            yield schemas.get(channel.schema_id), channel, record
        elif isinstance(record, Metadata | Attachment):
            yield record


def open_recording(path: Path) -> Recording:
    """Read the recording at ``path``; :class:`RecordingError` if it is none this code reads."""
    _check_file(path)
    metadata: dict[str, str] | None = None
    attachments: dict[str, bytes] = {}
    records: list[Record] = []
    inputs: list[Input] = []
    events: list[dict[str, Any]] = []
    marks: list[dict[str, Any]] = []
    logs: list[dict[str, Any]] = []
    scene: dict[str, tuple[Schema, bytes]] = {}
    problem: str | None = None
    start_ns: int | None = None
    with path.open("rb") as file:
        try:
            for item in _read_all(file):
                if isinstance(item, Metadata):
                    if item.name == ch.METADATA_NAME and metadata is None:
                        metadata = _check_metadata(path, dict(item.metadata))
                        start_ns = int(metadata["start_ns"])
                    continue
                if isinstance(item, Attachment):
                    attachments.setdefault(item.name, bytes(item.data))
                    continue
                if start_ns is None:
                    _check_metadata(path, None)  # raises: messages before any metadata of ours
                    continue
                _schema, channel, message = item
                t_ns = message.log_time - start_ns
                topic = channel.topic
                kind = ch.TYPE_OF_TOPIC.get(topic)
                if kind is not None and channel.message_encoding == "json":  # (format 1: a protobuf pose too)
                    fields = ch.record_fields(kind, json.loads(message.data))
                    records.append({"t": readable_seconds(t_ns), "t_ns": t_ns, "type": kind, **fields})
                elif topic == ch.INPUT_TOPIC:
                    data = json.loads(message.data)
                    inputs.append(Input(t_ns, data["topic"], data["sender"], data["data"]))
                elif topic == ch.EVENT_TOPIC:
                    events.append({"t_ns": t_ns, **json.loads(message.data)})
                elif topic == ch.MARK_CHANNEL:
                    marks.append({"t_ns": t_ns, **json.loads(message.data)})
                elif topic in (ch.MAP_TOPIC, ch.PLACES_TOPIC) and _schema is not None:
                    scene.setdefault(topic, (_schema, bytes(message.data)))
                elif topic == ch.DIAGNOSTIC_TOPIC:
                    diagnostic = json.loads(message.data)
                    kind_of = diagnostic.get("kind")
                    level = "warning" if kind_of in ("dropped", "crashed") else "info"
                    if kind_of == "rosout":  # another node's warning, error or fatal message
                        level = str(diagnostic.get("detail", {}).get("level", "warning"))
                    logs.append({"t_ns": t_ns, "level": level, **diagnostic})
        except (McapError, EOFError, ValueError, KeyError, struct.error) as exc:
            if metadata is None:
                raise RecordingError(
                    f"{path} is cut short or damaged before its first message ({exc}); fix: nothing can be "
                    "read from it: use an older segment of the recording"
                ) from exc
            problem = (
                f"{path} is cut short or damaged after {len(records)} records ({type(exc).__name__}: {exc}); "
                "read up to there (the recorder was stopped before it could finish the file)"
            )
    if metadata is None:
        metadata = _check_metadata(path, None)
    return Recording(path, metadata, attachments, records, inputs, events, marks, logs, problem, scene)


@dataclass(frozen=True)
class Glance:
    """What a finished recording's summary says, read without reading its messages."""

    path: Path
    metadata: dict[str, str]
    end_ns: int
    """The last message's time (``t_ns``)."""
    messages: int


def glance(path: Path) -> Glance | None:
    """A look at the recording at ``path`` through its summary (milliseconds, however long it is);
    :class:`RecordingError` if it is none this code reads; None if it has no summary (cut short:
    read it whole)."""
    _check_file(path)
    with path.open("rb") as file:
        reader = make_reader(file)
        try:
            summary = reader.get_summary()
            found = [m for m in reader.iter_metadata() if m.name == ch.METADATA_NAME] if summary else []
        except (McapError, EOFError, ValueError, struct.error):
            return None
        if summary is None or summary.statistics is None:
            return None
        metadata = _check_metadata(path, dict(found[0].metadata) if found else None)
        end_ns = max(0, summary.statistics.message_end_time - int(metadata["start_ns"]))
        return Glance(path, metadata, end_ns, summary.statistics.message_count)


def window(path: Path, start_ns: int, end_ns: int, topics: Iterable[str] | None = None) -> list[Record]:
    """The records between two moments (``t_ns``), read through the file's index (a seek): what a
    replay of a long recording reads without reading it whole. Needs a finished file."""
    _check_file(path)
    with path.open("rb") as file:
        reader = make_reader(file)
        try:
            found = [m for m in reader.iter_metadata() if m.name == ch.METADATA_NAME]
        except McapError as exc:
            raise RecordingError(
                f"{path} has no index (it was cut short: {exc}); fix: read it whole"
            ) from exc
        metadata = _check_metadata(path, dict(found[0].metadata) if found else None)
        start = int(metadata["start_ns"])
        wanted = list(topics) if topics is not None else list(ch.TYPE_OF_TOPIC)
        out: list[Record] = []
        for _schema, channel, message in reader.iter_messages(
            topics=wanted, starting_at=start + start_ns, ending_at=start + end_ns, log_time_order=False
        ):  # in the order written, as a whole read gives them (the robot's clock only moves on)
            if channel.message_encoding != "json":
                continue  # format 1's protobuf pose beside its JSON one
            t_ns = message.log_time - start
            kind = ch.TYPE_OF_TOPIC.get(channel.topic, channel.topic)
            fields = ch.record_fields(kind, json.loads(message.data))
            out.append({"t": readable_seconds(t_ns), "t_ns": t_ns, "type": kind, **fields})
        return out


def _decode(schema: Schema, data: bytes) -> Any:
    """A protobuf message of a Foxglove schema, decoded with the descriptors the file carries."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    files = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name)).FromString(data)


def recorded_map(recording: Recording) -> OccupancyMap | None:
    """The map the recording holds (its foxglove.Grid, with the places of its foxglove.SceneUpdate),
    or None: the robot had no map, or the message cannot be decoded."""
    import numpy as np

    from cyborg.maps import Cell, NamedPose, OccupancyMap

    found = recording.scene.get(ch.MAP_TOPIC)
    if found is None:
        return None
    try:
        grid = _decode(*found)
        cols = int(grid.column_count)
        values = np.frombuffer(grid.data, dtype=np.uint8)[: (len(grid.data) // cols) * cols]
        cells = np.full(values.shape, Cell.UNKNOWN, dtype=np.uint8)
        cells[values == 0] = Cell.FREE
        cells[values == 100] = Cell.OCCUPIED
        places: list[NamedPose] = []
        if ch.PLACES_TOPIC in recording.scene:
            for entity in _decode(*recording.scene[ch.PLACES_TOPIC]).entities:
                for sphere in entity.spheres[:1]:
                    places.append(NamedPose(entity.id, sphere.pose.position.x, sphere.pose.position.y, 0.0))
        return OccupancyMap(
            cells.reshape(-1, cols),
            float(grid.cell_size.x),
            (float(grid.pose.position.x), float(grid.pose.position.y)),
            poses=tuple(places),
            source=recording.path.name,
        )
    except Exception:  # a foreign or damaged map: the replay draws no map, and says nothing wrong
        return None
