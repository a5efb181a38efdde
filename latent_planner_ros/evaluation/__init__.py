"""Closed-loop evaluation shared by the demo and the benchmarks: trial metrics, statistics, pictures, the node
suites of the reach, conveyor and fault runs, and the probe nodes that watch them (``probes``).

``trial``, ``stats``, ``safety``, ``reach`` and the ``soak_*`` figures are ROS-free; ``conveyor_suite`` runs trials
through the node suite (processes) with the monitor node of ``latent_planner_ros.evaluation.probes.trial_monitor``.
Evaluation knows the nodes only by their names, topics and parameters, never by their code (import-linter checks it).
"""
