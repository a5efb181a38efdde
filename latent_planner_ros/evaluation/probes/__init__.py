"""Probe nodes: rclpy nodes that drive and watch the node suite from outside, for tests, benches and the demo.

Each runs spun in background threads on its own ROS context (``probe_session``). ``trial_monitor`` logs a
closed-loop trial, ``reach_probe`` asks a planner for a plan and executes it, ``fault_probe`` injects faults,
``soak_probe`` relays and interrupts the suite's inputs, ``graph_probe`` lists the graph's nodes (the
launcher's readiness check). They know the nodes only by their topics, services and parameters.
"""
