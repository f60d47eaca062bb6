"""The ROS 1 transport: the same interface over rospy and actionlib.

Each process is one ROS node (rospy allows no more); the components it hosts
are logical nodes sharing it, so their messages carry the process's node name
as sender (from the connection header's caller id), as in the thesis where the
controller, emotion system and motivator form the one node ``cyborg_controller``.

rospy calls back on its own threads; every callback is handed to the clock's
event loop with ``call_soon_threadsafe``, so components still run one callback
at a time. In real time the subscriptions of our components (and actionlib's inside
our action clients and servers) are read on the loop itself, so a message wakes one
thread, not two (:mod:`.reads`). Messages are converted field by field between our dataclasses and
the generated ROS classes (the names are the same by design).

Its modules, one idea each:

* :mod:`.transport`: :class:`RosTransport` and its nodes and parameters (start here);
* :mod:`.topics`, :mod:`.services`, :mod:`.actions`: what a node hands out
  (:mod:`cyborg.transport._host`: what they need of the transport);
* :mod:`.convert`: our messages to and from the generated ROS classes;
* :mod:`.master`: calls to the master, and living through its outage or restart;
  :mod:`.connections`: waiting until this process's topics are connected;
  :mod:`.graph`: the graph as the master lists it, each node asked whether it answers;
* :mod:`.patches`: rospy's behaviour changed, installed when a RosTransport is made
  (importing changes nothing); :mod:`.writes`: publishers writing at once when the socket
  takes it, :mod:`.reads`: subscriber connections read on the event loop (two of those changes).

The subscription queue, the client's goal handle and the message walk are the ones every
transport shares (:mod:`cyborg.transport._queue`, :mod:`cyborg.transport._goals`,
:mod:`cyborg.transport._convert`). This package is the only place that imports rospy.
"""

from cyborg.transport.ros.transport import RosNode, RosTransport

__all__ = ["RosNode", "RosTransport"]
