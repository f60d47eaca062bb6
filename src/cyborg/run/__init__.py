"""How a built robot runs: in this process, or one process per part on ROS 1 or ROS 2.

- :mod:`~cyborg.run.local`: the whole robot in this process on a real or virtual clock
  (``cyborg sim``); :mod:`~cyborg.run.datadir`: where the robot keeps its data.
- :mod:`~cyborg.run.middleware`: ROS 1 or ROS 2 as one strategy object (:data:`ROS1`,
  :data:`ROS2`): install checks, joining the graph, log files, node processes, the launch's
  graph; :mod:`~cyborg.run.master`: the ROS 1 master over XML-RPC; :mod:`~cyborg.run.ros2_env`:
  the ROS 2 venv's Python.
- :mod:`~cyborg.run.node`: one part as one node (``cyborg node``): build, wait, serve;
  :mod:`~cyborg.run.launched`: a launch's thin part started without click or pydantic;
  :mod:`~cyborg.run.logs`: where a node's log lines go; :mod:`~cyborg.run.census`: who else is
  on the graph (a name in use, another robot, the domain a robot must pick);
  :mod:`~cyborg.run.tasks`: pending tasks counted per module, a leak named.
- :mod:`~cyborg.run.supervisor`: every part as its own process, restarted when it stops
  (``cyborg launch``), forked from a :mod:`~cyborg.run.zygote` that imported what the nodes
  import; :mod:`~cyborg.run.roslaunch`: the same as a roslaunch file.
- :mod:`~cyborg.run.simtime`: virtual time shared by processes (the origin, ``/clock``);
  :mod:`~cyborg.run.lockstep`: the time server of lockstep time (``--speed max`` over ROS).
- :mod:`~cyborg.run.scenario`: a scenario script over ROS (the ``cyborg_scenario`` node).
- :mod:`~cyborg.run.doctor`: does this machine and its graph have what a configuration needs
  (``cyborg doctor``); :mod:`~cyborg.run.service`: the systemd unit that starts the robot at
  boot (``cyborg service``).
"""
