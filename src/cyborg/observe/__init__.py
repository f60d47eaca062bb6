"""What a run shows an observer: the record stream.

:mod:`~cyborg.observe.records` turns the robot's topics (state changes, emotions, what it says
and hears, poses, motivator decisions) into records with their clock time: scenario
transcripts, the HTTP API's event log and the dashboard read the same stream.
"""
