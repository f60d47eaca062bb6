"""The state machine drawn: where each state goes, and Graphviz.

:mod:`~cyborg.drawing.layout` lays a machine out (clusters for superstates, the arrows between
them) and runs Graphviz off the event loop; :mod:`~cyborg.drawing.graph` writes ``cyborg graph``'s
files and the dashboard's SVG. The controller does not need either: only the dashboard and the
command line do.
"""
