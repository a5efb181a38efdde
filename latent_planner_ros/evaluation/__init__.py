"""Closed-loop evaluation shared by the demo and the benchmarks: trial metrics, statistics, pictures.

``trial`` and ``stats`` are ROS-free; ``conveyor_suite`` runs trials through the node suite (processes)
with the monitor node of ``latent_planner_ros.nodes.trial_monitor``.
"""
