"""Export a recording as a ROS 1 bag or a ROS 2 bag: the thesis's messages on its topics.

Written with ``rosbags`` (no ROS needed): ``cyborg_controller/SystemState`` on
``/cyborg_controller/state_change``, ``cyborg_controller/EmotionalState`` on
``/cyborg_controller/emotional_state`` (their definitions are the package's own ``.msg`` files,
so the MD5 sums are ROS's), what was said and heard as ``std_msgs/String`` on ``/cyborg_tts/spoken``
and ``/text_from_speech``, every event on ``/cyborg_controller/register_event``, the motivator's
decisions (JSON) on ``/cyborg_controller/motivator_decision`` and the pose as
``geometry_msgs/PoseWithCovarianceStamped`` on ``/rosarnl_node/amcl_pose``.
"""

from __future__ import annotations

import json
import math
from enum import Enum
from importlib import resources
from pathlib import Path
from typing import Any

from cyborg.errors import CyborgError
from cyborg.observe.recording import Recording
from cyborg.transport import topics

__all__ = ["BagKind", "export"]

MESSAGES = ("SystemState", "EmotionalState")


class BagKind(Enum):
    ROSBAG = "rosbag"
    ROSBAG2 = "rosbag2"


def _typestore(kind: BagKind) -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if kind is BagKind.ROSBAG else Stores.ROS2_JAZZY)
    folder = resources.files("cyborg.observe") / "msg"
    types: dict[str, Any] = {}
    for name in MESSAGES:
        text = (folder / f"{name}.msg").read_text(encoding="utf-8")
        types.update(get_types_from_msg(text, f"cyborg_controller/msg/{name}"))
    store.register(types)
    return store


def export(recording: Recording, kind: BagKind, out: Path) -> int:
    """Write ``recording`` to ``out`` as a bag of ``kind``; returns the messages written."""
    if out.exists():
        raise CyborgError(f"{out} exists already; fix: give a new name with -o, or remove it first")
    store = _typestore(kind)
    std_string = "std_msgs/msg/String"
    state_type = "cyborg_controller/msg/SystemState"
    emotion_type = "cyborg_controller/msg/EmotionalState"
    pose_type = "geometry_msgs/msg/PoseWithCovarianceStamped"
    String = store.types[std_string]
    SystemState = store.types[state_type]
    EmotionalState = store.types[emotion_type]
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    PoseCov = store.types["geometry_msgs/msg/PoseWithCovariance"]
    Pose = store.types["geometry_msgs/msg/Pose"]
    Point = store.types["geometry_msgs/msg/Point"]
    Quaternion = store.types["geometry_msgs/msg/Quaternion"]
    import numpy as np

    messages: list[tuple[int, str, str, Any]] = []
    start = recording.start_ns
    emotion = "neutral"
    for record in recording.records:
        stamp = start + int(record["t_ns"])
        kind_of = record["type"]
        if kind_of == "state":
            message = SystemState(
                event=record["event"], from_system_state=record["from"] or "", to_system_state=record["to"]
            )
            messages.append((stamp, topics.STATE_CHANGE, state_type, message))
        elif kind_of == "emotion":
            message = EmotionalState(
                from_emotional_state=emotion,
                to_emotional_state=record["emotion"],
                current_pleasure=float(record["pleasure"]),
                current_arousal=float(record["arousal"]),
                current_dominance=float(record["dominance"]),
            )
            emotion = str(record["emotion"])
            messages.append((stamp, topics.EMOTIONAL_STATE, emotion_type, message))
        elif kind_of in ("say", "heard"):
            topic = topics.SPOKEN_TOPIC if kind_of == "say" else topics.TEXT_FROM_SPEECH
            messages.append((stamp, topic, std_string, String(data=record["text"])))
        elif kind_of == "motivator":
            fields = {k: v for k, v in record.items() if k not in ("t", "t_ns", "type")}
            messages.append((stamp, topics.MOTIVATOR_DECISION, std_string, String(data=json.dumps(fields))))
        elif kind_of == "pose":
            sec, nsec = divmod(stamp, 1_000_000_000)
            half = float(record["theta"]) / 2.0
            message = store.types[pose_type](
                header=Header(stamp=Time(sec=sec, nanosec=nsec), frame_id="map")
                if kind is BagKind.ROSBAG2
                else _ros1_header(store, sec, nsec),
                pose=PoseCov(
                    pose=Pose(
                        position=Point(x=float(record["x"]), y=float(record["y"]), z=0.0),
                        orientation=Quaternion(x=0.0, y=0.0, z=math.sin(half), w=math.cos(half)),
                    ),
                    covariance=np.zeros(36, dtype=np.float64),
                ),
            )
            messages.append((stamp, topics.AMCL_POSE, pose_type, message))
    for event in recording.events:
        stamp = start + int(event["t_ns"])
        messages.append((stamp, topics.REGISTER_EVENT, std_string, String(data=str(event["event"]))))
    messages.sort(key=lambda m: m[0])
    try:
        _write(kind, out, store, messages)
    except OSError as exc:
        raise CyborgError(f"cannot write {out}: {exc.strerror}; fix: give a writable path with -o") from exc
    return len(messages)


def _ros1_header(store: Any, sec: int, nsec: int) -> Any:
    Header = store.types["std_msgs/msg/Header"]
    Time = store.types["builtin_interfaces/msg/Time"]
    return Header(seq=0, stamp=Time(sec=sec, nanosec=nsec), frame_id="map")


def _write(kind: BagKind, out: Path, store: Any, messages: list[tuple[int, str, str, Any]]) -> None:
    if kind is BagKind.ROSBAG:
        from rosbags.rosbag1 import Writer as Writer1

        with Writer1(out) as writer:
            connections: dict[str, Any] = {}
            for stamp, topic, msgtype, message in messages:
                if topic not in connections:
                    connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
                writer.write(connections[topic], stamp, store.serialize_ros1(message, msgtype))
        return
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    with Writer2(out, version=9, storage_plugin=StoragePlugin.MCAP) as writer2:
        connections2: dict[str, Any] = {}
        for stamp, topic, msgtype, message in messages:
            if topic not in connections2:
                connections2[topic] = writer2.add_connection(topic, msgtype, typestore=store)
            writer2.write(connections2[topic], stamp, store.serialize_cdr(message, msgtype))
