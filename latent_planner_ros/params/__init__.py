"""The parameter bridge of the suite's nodes: a config dataclass <-> ROS parameters.

`config` (no ROS): flatten a dataclass to dotted names and back, with each field's validation (`from_params`,
`to_params`, `ConfigError`); `specs` (no ROS): each parameter's type, description (the field's docstring), unit
range and read-only flag; `ros`: `ConfigParams` declares them on an rclpy node with descriptors and screens
changes. Every node of the suite (the sim's too) declares its parameters through it.
"""
