"""OpenAPI 3 description of the robot's local HTTP API (served at /api/openapi.json)."""

from __future__ import annotations

from typing import Any


def _command(summary: str, schema: dict[str, Any]) -> dict[str, Any]:
    return {
        "post": {
            "summary": summary,
            "requestBody": {"required": True, "content": {"application/json": {"schema": schema}}},
            "responses": {
                "200": {
                    "description": "sent; an emotion command's answer has saved false and a 'warning' "
                    "while the robot cannot save its data (the change is made in memory only)",
                    "content": {"application/json": {"schema": {"type": "object"}}},
                },
                "400": {"description": "bad input; the body's 'error' names the problem"},
                "413": {"description": "the body is over the API's limit (64 KiB)"},
                "415": {"description": "the body was not sent as Content-Type: application/json"},
            },
        }
    }


def _object(**properties: dict[str, Any]) -> dict[str, Any]:
    return {"type": "object", "required": list(properties), "properties": properties}


STATUS_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "state": {"type": "string", "nullable": True},
        "previous_state": {"type": "string", "nullable": True},
        "event": {"type": "string", "nullable": True},
        "emotion": {"type": "string"},
        "pleasure": {"type": "number"},
        "arousal": {"type": "number"},
        "dominance": {"type": "number"},
        "valid_events": {"type": "array", "items": {"type": "string"}},
        "time": {"type": "number", "description": "robot clock, seconds since the epoch"},
        "graph": {
            "type": "string",
            "description": "the graph the robot's parts meet on: 'in this process (no ROS graph)', "
            "'ROS 1 master URI' or 'ROS 2 domain N (discovery: ...)'",
        },
        "storage": {
            "type": "object",
            "nullable": True,
            "description": "whether the controller's data (emotion, switch, saturations) is saved; "
            "saved false: 'problem' and 'fix' say why, 'unsaved' what is kept in memory until a "
            "write works (then it is written); absent where not known (under ROS)",
            "properties": {
                "path": {"type": "string"},
                "saved": {"type": "boolean"},
                "problem": {"type": "string", "nullable": True},
                "fix": {"type": "string", "nullable": True},
                "failed_writes": {"type": "integer"},
                "unsaved": {"type": "array", "items": {"type": "string"}},
            },
        },
        "blocked": {
            "type": "object",
            "nullable": True,
            "description": "the last time a callback blocked the in-process robot's event loop (everything "
            "stood still meanwhile): the callback, its module, file and line, how long, whether the watchdog "
            "stopped it to keep the controller's handover deadline, and the fix; "
            "null if never, absent under ROS",
        },
    },
}

OPENAPI: dict[str, Any] = {
    "openapi": "3.0.3",
    "info": {
        "title": "Cyborg robot API",
        "version": "1",
        "description": "Commands and status of a running Cyborg. Every answer may also be 403 (a Host or "
        "Origin that is not the robot's, see docs/security.md), 401 (the robot serves beyond loopback "
        "or was given --token: send 'Authorization: Bearer TOKEN'; the websocket also takes ?token=) "
        "or 503 (a connection or stream limit); the body's 'error' names the limit and the fix.",
    },
    "components": {"securitySchemes": {"token": {"type": "http", "scheme": "bearer"}}},
    "security": [{}, {"token": []}],
    "paths": {
        "/api/status": {
            "get": {
                "summary": "Previous state, event, current state, emotion and PAD values",
                "responses": {
                    "200": {
                        "description": "status",
                        "content": {"application/json": {"schema": STATUS_SCHEMA}},
                    }
                },
            }
        },
        "/api/event": _command(
            "Publish an event on /cyborg_controller/register_event", _object(name={"type": "string"})
        ),
        "/api/say": _command(
            "Publish text on /text_from_speech, as speech-to-text would", _object(text={"type": "string"})
        ),
        "/api/emotion/set": _command("Set the emotion by name", _object(name={"type": "string"})),
        "/api/emotion/values": _command(
            "Set the PAD values",
            _object(
                pleasure={"type": "number", "minimum": -1, "maximum": 1},
                arousal={"type": "number", "minimum": -1, "maximum": 1},
                dominance={"type": "number", "minimum": -1, "maximum": 1},
            ),
        ),
        "/api/emotion/switch": _command(
            "Switch the emotion system on or off", _object(on={"type": "boolean"})
        ),
        "/api/records": {
            "get": {
                "summary": "Recent records (state, emotion, say, heard, pose, motivator)",
                "parameters": [
                    {"name": "since", "in": "query", "schema": {"type": "integer"}},
                    {
                        "name": "type",
                        "in": "query",
                        "schema": {"type": "string"},
                        "description": "comma-separated record types",
                    },
                ],
                "responses": {
                    "200": {
                        "description": "records",
                        "content": {"application/json": {"schema": {"type": "array"}}},
                    }
                },
            }
        },
        "/api/machine": {
            "get": {
                "summary": "The state machine: states, superstates, transitions, resources",
                "responses": {"200": {"description": "machine"}},
            }
        },
        "/api/graph.svg": {
            "get": {
                "summary": "The state machine drawn by Graphviz (node ids state:<name>), laid out once; "
                "a machine too big or too slow to lay out is listed instead (header X-Graph-Layout: list)",
                "responses": {"200": {"description": "SVG"}},
            }
        },
        "/api/emotions": {
            "get": {
                "summary": "The emotion prototypes (PAD points)",
                "responses": {"200": {"description": "prototypes"}},
            }
        },
        "/api/recorder": {
            "get": {
                "summary": "The flight recorder: recording (true/false), state, file, problem (why it stopped)",
                "responses": {"200": {"description": "the recorder's status"}},
            }
        },
        "/api/mark": _command(
            "Put a note into the recording at this moment (the dashboard's mark button); 400 when "
            "the robot is not recording",
            {"type": "object", "properties": {"note": {"type": "string", "maxLength": 500}}},
        ),
        "/api/lookback/replay": {
            "get": {
                "summary": "The last minutes of the recording (as cyborg replay's /api/replay); then "
                "/api/lookback/status?at=SECONDS and /api/lookback/records?at=SECONDS answer as at that moment",
                "parameters": [{"name": "minutes", "in": "query", "schema": {"type": "number"}}],
                "responses": {
                    "200": {"description": "span, marks, track and emotion plot"},
                    "400": {"description": "the robot is not recording; 'error' says why"},
                },
            }
        },
        "/api/ws": {
            "get": {
                "summary": "Websocket: a hello with the status, then every record as JSON",
                "responses": {"101": {"description": "switching protocols"}},
            }
        },
    },
}
