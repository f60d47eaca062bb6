"""Talking to a running robot, as the command tool does.

:mod:`~cyborg.client.http` speaks to the robot's HTTP API (``cyborg sim``, or the ``cyborg_api``
node) with urllib alone; :mod:`~cyborg.client.ros` joins the robot's ROS 1 or ROS 2 graph as a
short-lived node and uses the thesis's topics and services. Both are a
:class:`~cyborg.client.http.RobotLink`.
"""
