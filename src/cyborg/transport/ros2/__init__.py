"""The ROS 2 transport: the same interface over rclpy and ``rclpy.action`` (ROS 2 Kilted).

It runs in ``.venv-ros2`` (``scripts/install-ros2``), never in the ROS 1 venv: both install a
top-level ``std_msgs``. Every logical node is an rclpy node (rclpy allows many per process),
so a message's sender is the node that published it (:mod:`.topics`: from its publisher's
GID). Latched topics are transient-local; actions keep actionlib's meaning (:mod:`.actions`);
parameters live on one parameter home node (:mod:`.transport`). See docs/ros2.md.

Its modules, one idea each:

* :mod:`.transport`: :class:`Ros2Transport`, its nodes and parameters (start here);
* :mod:`.topics`, :mod:`.services`, :mod:`.actions`: what a node hands out
  (:mod:`.host`: what they need of the transport);
* :mod:`.convert`: our messages to and from the generated ROS 2 classes;
* :mod:`.executor`: the executor that spins the rclpy nodes and hands work over to the loop.

The subscription queue, the client's goal handle and the message walk are the ones every
transport shares (:mod:`cyborg.transport._queue`, :mod:`cyborg.transport._goals`,
:mod:`cyborg.transport._convert`). This package is the only place that imports rclpy.
"""

from cyborg.transport.ros2.transport import Ros2Node, Ros2Transport

__all__ = ["Ros2Node", "Ros2Transport"]
