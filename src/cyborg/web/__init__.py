"""The robot's HTTP API and live dashboard: the only package that serves HTTP.

:mod:`~cyborg.web.build` assembles them once, for the in-process robot and for the
``cyborg_api`` node alike; :mod:`~cyborg.web.api` holds the API (commands, status, records,
the machine's graph, a websocket) and :mod:`~cyborg.web.openapi` its description;
:mod:`~cyborg.web.dashboard` the page and its endpoints (``static/``);
:mod:`~cyborg.web.ros_view` reads a robot whose parts run as other ROS nodes.
:mod:`~cyborg.web.access` is the access policy as the command line sees it (no aiohttp), and
:mod:`~cyborg.web.security` the server's checks of it, :mod:`~cyborg.web.request_log` what the server logs of bad requests
(one short line at most every few seconds). :mod:`~cyborg.web.replay` serves the
dashboard on a recording (``cyborg replay``), and :mod:`~cyborg.web.lookback` lets the live
dashboard mark a moment and look back at the last minutes from the running robot's recording.
"""
