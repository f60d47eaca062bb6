"""The navigation module (thesis chapter 7): places, the calendar, what people ask, trips and what to say.

- :mod:`~cyborg.navigation.module`: the module itself, serving the planning, moving and talking
  states; :mod:`~cyborg.navigation.kind`: its settings and factory; :mod:`~cyborg.navigation.base_link`:
  how it drives the base (ROSARNL's interface or nav2's); :mod:`~cyborg.navigation.watchdog`: when a
  trip is given up (a base that never answers, a pose gone silent).
- :mod:`~cyborg.navigation.behaviour` (where to go, what to say),
  :mod:`~cyborg.navigation.dialogue` (what the talking state answers a request, and requests that
  wait for a yes or no) and :mod:`~cyborg.navigation.keywords` (what was asked): its pure decisions.
- :mod:`~cyborg.navigation.database`: the SQLite database, a front over :mod:`~cyborg.navigation.schema`
  (tables and migrations), :mod:`~cyborg.navigation.locations` (places), :mod:`~cyborg.navigation.events`
  (calendar events), :mod:`~cyborg.navigation.responses` (sentences) and
  :mod:`~cyborg.navigation.content` (what a new database starts with); its value types are in
  :mod:`~cyborg.navigation.models`, and :mod:`~cyborg.navigation.map_import` makes a map's goals places.
- :mod:`~cyborg.navigation.calendar`: the calendar as the rest of the robot sees it;
  :mod:`~cyborg.navigation.recurrence` expands recurring events and :mod:`~cyborg.navigation.ics`
  imports ``.ics`` files.
"""
