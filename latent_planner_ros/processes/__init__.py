"""The node suite as operating-system processes: command lines (``node_suite``) and their supervision
(``supervisor``). No ROS here: a node is named by its ``registry`` entry and started as a process.
"""
