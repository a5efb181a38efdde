"""The live 3D view of the suite in the browser (viser). No ROS here: nodes/view.py subscribes to the topics and
hands numpy arrays to :class:`~latent_planner_ros.view.scene.SuiteScene`."""
