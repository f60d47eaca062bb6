"""Message, service and action types shared by every component.

Field names mirror the Cyborg's ROS messages exactly (thesis chapter 8), so the
ROS transport can convert them field by field and existing Cyborg modules keep
working. Each type carries its ROS type name in ``ros_type``.
"""

from __future__ import annotations

import dataclasses
import math
import struct
from dataclasses import dataclass, field
from typing import Any, ClassVar, Generic, TypeVar


@dataclass(frozen=True)
class Message:
    """Base class of all message types: a frozen dataclass, so a message cannot change once made.

    The embedded transport hands the same object to every subscriber (no copy); a message type
    with a mutable field (a list, a dict) is copied for each subscriber instead. Make a changed
    message with ``dataclasses.replace``.
    """

    ros_type: ClassVar[str] = ""

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def float32(value: float) -> float:
    """``value`` as a ROS ``float32`` field carries it, written with the fewest digits that give
    that ``float32`` back (0.1 stays 0.1; 0.123456789 becomes 0.12345679; out of range: infinite)."""
    try:
        wire = struct.unpack("<f", struct.pack("<f", value))[0]
    except OverflowError:
        return math.copysign(math.inf, value)
    except (struct.error, TypeError):
        return value  # not a number: what takes the message says so
    if not math.isfinite(wire) or wire == 0.0:
        return float(wire)
    for digits in range(1, 10):
        shortest = float(f"{wire:.{digits}g}")
        if struct.unpack("<f", struct.pack("<f", shortest))[0] == wire:
            return shortest
    return float(wire)


def _as_float32(message: Message, *names: str) -> None:
    """Round the ``float32`` fields of a new message as the wire does (:func:`float32`), in one
    process too: a robot in one process then computes with the numbers its ROS graph receives."""
    for name in names:
        object.__setattr__(message, name, float32(getattr(message, name)))


M = TypeVar("M", bound=Message)
Req = TypeVar("Req", bound=Message)
Resp = TypeVar("Resp", bound=Message)
G = TypeVar("G", bound=Message)
R = TypeVar("R", bound=Message)
F = TypeVar("F", bound=Message)


# --- std_msgs / std_srvs ---------------------------------------------------


@dataclass(frozen=True)
class String(Message):
    ros_type: ClassVar[str] = "std_msgs/String"
    data: str = ""


@dataclass(frozen=True)
class Empty(Message):
    ros_type: ClassVar[str] = "std_msgs/Empty"


@dataclass(frozen=True)
class Clock(Message):
    """Simulated time on ``/clock`` (rosgraph_msgs/Clock): nodes with /use_sim_time follow it."""

    ros_type: ClassVar[str] = "rosgraph_msgs/Clock"
    clock: float = 0.0


# --- cyborg_controller -----------------------------------------------------


@dataclass(frozen=True)
class SystemState(Message):
    """Published on every state change of the controller's state machine."""

    ros_type: ClassVar[str] = "cyborg_controller/SystemState"
    event: str = ""
    from_system_state: str = ""
    to_system_state: str = ""


@dataclass(frozen=True)
class EmotionalFeedback(Message):
    """A change in the PAD values sent by a module (absolute values on set_emotional_values)."""

    ros_type: ClassVar[str] = "cyborg_controller/EmotionalFeedback"
    delta_pleasure: float = 0.0
    delta_arousal: float = 0.0
    delta_dominance: float = 0.0

    def __post_init__(self) -> None:
        _as_float32(self, "delta_pleasure", "delta_arousal", "delta_dominance")


@dataclass(frozen=True)
class EmotionalState(Message):
    ros_type: ClassVar[str] = "cyborg_controller/EmotionalState"
    from_emotional_state: str = ""
    to_emotional_state: str = ""
    current_pleasure: float = 0.0
    current_arousal: float = 0.0
    current_dominance: float = 0.0

    def __post_init__(self) -> None:
        _as_float32(self, "current_pleasure", "current_arousal", "current_dominance")


@dataclass(frozen=True)
class EmotionalStateServiceRequest(Message):
    ros_type: ClassVar[str] = "cyborg_controller/EmotionalStateServiceRequest"


@dataclass(frozen=True)
class EmotionalStateServiceResponse(Message):
    ros_type: ClassVar[str] = "cyborg_controller/EmotionalStateServiceResponse"
    emotional_state: str = ""
    current_pleasure: float = 0.0
    current_arousal: float = 0.0
    current_dominance: float = 0.0

    def __post_init__(self) -> None:
        _as_float32(self, "current_pleasure", "current_arousal", "current_dominance")


@dataclass(frozen=True)
class StateMachineGoal(Message):
    ros_type: ClassVar[str] = "cyborg_controller/StateMachineGoal"
    previous_state: str = ""
    event: str = ""
    current_state: str = ""


@dataclass(frozen=True)
class StateMachineResult(Message):
    ros_type: ClassVar[str] = "cyborg_controller/StateMachineResult"
    status: str = ""
    message: str = ""


@dataclass(frozen=True)
class StateMachineFeedback(Message):
    ros_type: ClassVar[str] = "cyborg_controller/StateMachineFeedback"
    status: str = ""
    message: str = ""


# --- geometry / navigation -------------------------------------------------


@dataclass(frozen=True)
class Point(Message):
    ros_type: ClassVar[str] = "geometry_msgs/Point"
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


@dataclass(frozen=True)
class Quaternion(Message):
    ros_type: ClassVar[str] = "geometry_msgs/Quaternion"
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


@dataclass(frozen=True)
class Pose(Message):
    ros_type: ClassVar[str] = "geometry_msgs/Pose"
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass(frozen=True)
class Header(Message):
    ros_type: ClassVar[str] = "std_msgs/Header"
    seq: int = 0
    stamp: float = 0.0
    frame_id: str = ""


@dataclass(frozen=True)
class PoseStamped(Message):
    ros_type: ClassVar[str] = "geometry_msgs/PoseStamped"
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass(frozen=True)
class PoseWithCovariance(Message):
    ros_type: ClassVar[str] = "geometry_msgs/PoseWithCovariance"
    pose: Pose = field(default_factory=Pose)
    covariance: tuple[float, ...] = (0.0,) * 36


@dataclass(frozen=True)
class PoseWithCovarianceStamped(Message):
    """The base's localised pose (rosarnl's ``amcl_pose``); covariance left at zero."""

    ros_type: ClassVar[str] = "geometry_msgs/PoseWithCovarianceStamped"
    header: Header = field(default_factory=Header)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@dataclass(frozen=True)
class MoveBaseGoal(Message):
    ros_type: ClassVar[str] = "move_base_msgs/MoveBaseGoal"
    target_pose: PoseStamped = field(default_factory=PoseStamped)


@dataclass(frozen=True)
class MoveBaseFeedback(Message):
    ros_type: ClassVar[str] = "move_base_msgs/MoveBaseFeedback"
    base_position: PoseStamped = field(default_factory=PoseStamped)


@dataclass(frozen=True)
class MoveBaseResult(Message):
    ros_type: ClassVar[str] = "move_base_msgs/MoveBaseResult"


@dataclass(frozen=True)
class NavigateToPoseGoal(Message):
    """Where the base is to go (ROS 2, nav2's fields); ``behavior_tree`` ``wander``
    (:data:`~cyborg.transport.topics.WANDER_BEHAVIOR`) asks the simulated base to wander until cancelled."""

    ros_type: ClassVar[str] = "cyborg_controller/NavigateToPoseGoal"
    pose: PoseStamped = field(default_factory=PoseStamped)
    behavior_tree: str = ""


@dataclass(frozen=True)
class NavigateToPoseFeedback(Message):
    """Where the base is and how far it still has to drive (metres along its route); times in seconds."""

    ros_type: ClassVar[str] = "cyborg_controller/NavigateToPoseFeedback"
    current_pose: PoseStamped = field(default_factory=PoseStamped)
    navigation_time: float = 0.0
    estimated_time_remaining: float = 0.0
    number_of_recoveries: int = 0
    distance_remaining: float = 0.0


@dataclass(frozen=True)
class NavigateToPoseResult(Message):
    """Empty on success; an aborted goal says why in ``error_msg`` (``error_code`` 0 unless set)."""

    ros_type: ClassVar[str] = "cyborg_controller/NavigateToPoseResult"
    error_code: int = 0
    error_msg: str = ""


@dataclass(frozen=True)
class EmptyRequest(Message):
    ros_type: ClassVar[str] = "std_srvs/EmptyRequest"


@dataclass(frozen=True)
class EmptyResponse(Message):
    ros_type: ClassVar[str] = "std_srvs/EmptyResponse"


# --- service and action type descriptors -----------------------------------


@dataclass(frozen=True)
class ServiceType(Generic[Req, Resp]):
    ros_type: str
    request: type[Req]
    response: type[Resp]


@dataclass(frozen=True)
class ActionType(Generic[G, R, F]):
    ros_type: str
    goal: type[G]
    result: type[R]
    feedback: type[F]


EmotionalStateService: ServiceType[EmotionalStateServiceRequest, EmotionalStateServiceResponse] = ServiceType(
    "cyborg_controller/EmotionalStateService",
    EmotionalStateServiceRequest,
    EmotionalStateServiceResponse,
)
EmptyService: ServiceType[EmptyRequest, EmptyResponse] = ServiceType(
    "std_srvs/Empty", EmptyRequest, EmptyResponse
)
StateMachineAction: ActionType[StateMachineGoal, StateMachineResult, StateMachineFeedback] = ActionType(
    "cyborg_controller/StateMachineAction",
    StateMachineGoal,
    StateMachineResult,
    StateMachineFeedback,
)
MoveBaseAction: ActionType[MoveBaseGoal, MoveBaseResult, MoveBaseFeedback] = ActionType(
    "move_base_msgs/MoveBaseAction", MoveBaseGoal, MoveBaseResult, MoveBaseFeedback
)
NavigateToPoseAction: ActionType[NavigateToPoseGoal, NavigateToPoseResult, NavigateToPoseFeedback] = (
    ActionType(
        "cyborg_controller/NavigateToPoseAction",
        NavigateToPoseGoal,
        NavigateToPoseResult,
        NavigateToPoseFeedback,
    )
)


_IMMUTABLE_VALUES = (str, int, float, bool, bytes, type(None))


def _immutable_value(value: Any) -> bool:
    if isinstance(value, _IMMUTABLE_VALUES):
        return True
    if isinstance(value, tuple):
        return all(_immutable_value(item) for item in value)
    return isinstance(value, Message) and is_immutable(type(value))


def is_immutable(cls: type[Message]) -> bool:
    """True if a ``cls`` message cannot change once made: frozen, and every field's default is a
    number, string, tuple of those or an immutable message (so transports may share one object).

    A message type with a list or dict field is mutable: the embedded transport gives each
    subscriber its own copy of it.
    """
    cached = _immutable.get(cls)
    if cached is None:
        params = getattr(cls, "__dataclass_params__", None)
        cached = bool(params is not None and params.frozen)
        for f in dataclasses.fields(cls) if cached else ():
            if f.default is not dataclasses.MISSING:
                default = f.default
            elif f.default_factory is not dataclasses.MISSING:
                default = f.default_factory()
            else:
                cached = False
                break
            if not _immutable_value(default):
                cached = False
                break
        _immutable[cls] = cached
    return cached


_immutable: dict[type[Message], bool] = {}
