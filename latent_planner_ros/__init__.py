"""latent_planner_ros: learned latent-space motion planning for the Franka Panda.

The core (``robot``, ``models``, ``planning``, ``data``, ``training``, ``bench``) imports no rclpy;
only ``nodes`` does.
"""

__version__ = "0.1.0"
