"""The composition root: reads the configuration and builds the robot from it.

One place builds everything, for the in-process robot and for each ROS node alike:
the controller trio (state machine, emotion system, motivator) with its store, the
module kinds found through entry points, the gatekeepers and the base.

- :mod:`~cyborg.app.config`: the whole configuration file (machine, emotion, motivator, modules).
- :mod:`~cyborg.app.registry`: the module kinds, found through entry points and loaded lazily
  (from the main venv's packages too, in the ROS 2 venv: :mod:`~cyborg.app.plugin_path`);
  :mod:`~cyborg.app.kinds_doc` writes their settings as Markdown; :mod:`~cyborg.app.checks`
  warns about a robot whose modules and states do not fit together.
- :mod:`~cyborg.app.context`: what a module's factory builds with (data folder, randomness, map);
  :mod:`~cyborg.app.world`: which map the robot lives on (the Glassgården scan when found).
- :mod:`~cyborg.app.robot`: the in-process robot; :mod:`~cyborg.app.parts`: the part of one ROS
  node (a module's or gatekeeper's built from a :mod:`~cyborg.app.sketch` of a configuration the
  launch validated); :mod:`~cyborg.app.view`: what the dashboard reads of either.
- :mod:`~cyborg.app.tuning`: the garbage collector and allocator set for a long-lived robot.
"""
