"""The composition root: reads the configuration and builds the robot from it.

One place builds everything, for the in-process robot and for each ROS node alike:
the controller trio (state machine, emotion system, motivator) with its store, the
module kinds found through entry points, the gatekeepers and the base.
"""
