"""Perception for the nodes, free of ROS: preparing point clouds for the scene encoder."""
