"""Runs recorded as rosbag2 MCAP bags, and read back for replay. No ROS here: the recorder and player nodes
(nodes/bag_recorder.py, nodes/bag_player.py) hand over serialized (CDR) messages."""
