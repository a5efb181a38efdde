"""rclpy nodes: thin wiring between ROS topics/services and the ROS-free core.

A node converts messages with `msg_adapters`, calls one core function and publishes.
Each module exposes `main()` (no arguments; reads sys.argv including ROS arguments).
The probe nodes of tests and benches live in `latent_planner_ros.evaluation.probes`.
"""
