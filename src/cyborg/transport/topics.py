"""Topic, service, action and parameter names of the Cyborg's ROS graph (thesis ch. 8-9).

Every component uses these constants, so the embedded and ROS transports carry
exactly the names existing Cyborg modules use.
"""

import enum

CONTROLLER_NODE = "cyborg_controller"
"""The controller's node: the only publisher of state changes that observers believe."""
REGISTER_EVENT = "/cyborg_controller/register_event"
STATE_CHANGE = "/cyborg_controller/state_change"
STATE_RESOURCES_PARAM = "/state_resources"
# Ours, not the thesis's: the controller's counters as JSON (std_msgs/String).
CONTROLLER_STATS = "/cyborg_controller/stats"
# Ours: in a parallel state, the region modules muted because a higher-priority region holds
# their resource, as JSON {states: [...], muted: [{resource, node, state, region, holder}]}
# (std_msgs/String, latched; published whenever the parallel state's configuration changes).
RESOURCE_MUTES = "/cyborg_controller/muted"
# Ours: each state's transitions ({state: [event, ...]}), set once when the controller starts,
# so tools over ROS can tell whether an event would be taken.
TRANSITIONS_PARAM = "/cyborg_controller/transitions"

EMOTIONAL_FEEDBACK = "/cyborg_controller/emotional_feedback"
EMOTIONAL_STATE = "/cyborg_controller/emotional_state"
GET_EMOTIONAL_STATE = "/cyborg_controller/get_emotional_state"
SET_EMOTIONAL_STATE = "/cyborg_controller/set_emotional_state"
SET_EMOTIONAL_VALUES = "/cyborg_controller/set_emotional_values"
EMOTIONAL_CONTROLLER = "/cyborg_controller/emotional_controller"
MOTIVATOR_DECISION = "/cyborg_controller/motivator_decision"
EMOTION_ENABLED_PARAM = "/cyborg_controller/emotion_enabled"

TEXT_TO_SPEECH = "/text_to_speech"
TEXT_FROM_SPEECH = "/text_from_speech"
# Ours: what observers (scenario runs) learn of things that went wrong quietly, as JSON
# (std_msgs/String): a message a gatekeeper dropped, a module goal that raised; and what a
# gatekeeper passed (the flight recorder keeps both).
GATEKEEPER_DROPPED = "/cyborg_diagnostics/dropped"
GATEKEEPER_PASSED = "/cyborg_diagnostics/passed"
MODULE_CRASHED = "/cyborg_diagnostics/crashed"
# Ours: a problem a module has and cannot fix itself (no sound device, a base that does not
# answer), and when it is over, as JSON {module, key, problem, fix, active} (std_msgs/String).
PROBLEMS = "/cyborg_diagnostics/problems"
# Ours: what the text-to-speech module is asked to say, and what it has said (std_msgs/String).
SPEECH_INPUT_TOPIC = "/cyborg_tts/say"
SPOKEN_TOPIC = "/cyborg_tts/spoken"
# Ours: every utterance the speech input decoded, as JSON {text, confidence, accepted, raw} (std_msgs/String).
SPEECH_HEARD = "/cyborg_speech/heard"
# Ours: a sentence the speech input heard but is unsure of the place in, as JSON {text, place,
# confidence, reason} (std_msgs/String). It is NOT on /text_from_speech (a module that reads only
# that never acts on a doubtful place); a module that can ask ("Did you mean the elevator?") may.
SPEECH_UNSURE = "/cyborg_speech/unsure"

MOVE_BASE = "/rosarnl_node/move_base"
WANDER = "/rosarnl_node/wander"
STOP = "/rosarnl_node/stop"
AMCL_POSE = "/rosarnl_node/amcl_pose"
ARNL_PATH_STATE = "/rosarnl_node/arnl_path_state"
# ROS 2: the base's navigation is nav2's action (our NavigateToPose interface; no wander/stop
# services: a goal whose behavior_tree is WANDER_BEHAVIOR wanders until it is cancelled).
NAVIGATE_TO_POSE = "/navigate_to_pose"
WANDER_BEHAVIOR = "wander"


class BaseApi(enum.StrEnum):
    """The robot base's navigation interface: the Pioneer LX's ROSARNL, or nav2's on ROS 2."""

    ROSARNL = "rosarnl"
    """``move_base`` action plus the ``wander`` and ``stop`` services (thesis ch. 9)."""
    NAV2 = "nav2"
    """nav2's ``navigate_to_pose`` action; a goal whose ``behavior_tree`` is WANDER_BEHAVIOR wanders."""
