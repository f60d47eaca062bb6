"""What a run shows an observer: the record stream, and the flight recorder.

:mod:`~cyborg.observe.records` turns the robot's topics (state changes, emotions, what it says
and hears, poses, motivator decisions) into records with their clock time (integer
nanoseconds): scenario transcripts, the HTTP API's event log and the dashboard read the same
stream. :mod:`~cyborg.observe.recorder` writes every run to MCAP as it happens, on the channels
:mod:`~cyborg.observe.channels` names; :mod:`~cyborg.observe.recording` reads a recording back
(replay, re-run) and :mod:`~cyborg.observe.export` writes it as a ROS 1 or ROS 2 bag;
:mod:`~cyborg.observe.rosout` brings a launch's other nodes' warnings and errors (ROS's
``/rosout``) to the recorder.
"""
