"""ROS 2 launch file for the closed-loop suite: sim, scene_encoder and planner.

    ros2 launch latent_planner_ros latent_planner.launch.py [scenario:=tabletop] [use_sim_time:=true]

Needs a full ROS 2 install (the ``launch`` and ``launch_ros`` packages) and the package built with colcon.
Each node reads its ``config/<node>.yaml`` from the package's share directory (when the file exists);
``scenario`` (a name in config/scenarios or a YAML path) overrides the sim's parameter of that name.
Without ROS 2 launch, ``python -m latent_planner_ros launch`` starts the same suite.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument
from launch.launch_description import LaunchDescription
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

PACKAGE = "latent_planner_ros"


def _params_files(node: str) -> list[str]:
    """[share/latent_planner_ros/config/<node>.yaml] if the package installs one, else []."""
    path = os.path.join(get_package_share_directory(PACKAGE), "config", f"{node}.yaml")
    return [path] if os.path.isfile(path) else []


def generate_launch_description() -> LaunchDescription:
    use_sim_time = {"use_sim_time": ParameterValue(LaunchConfiguration("use_sim_time"), value_type=bool)}
    scenario = {"scenario": ParameterValue(LaunchConfiguration("scenario"), value_type=str)}
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "scenario",
                default_value="conveyor",
                description="the sim's scenario: a name in config/scenarios (tabletop, conveyor, ...) or a YAML path",
            ),
            DeclareLaunchArgument(
                "use_sim_time", default_value="true", description="run every node on the sim's /clock"
            ),
            Node(
                package=PACKAGE,
                executable="sim",
                name="sim",
                output="screen",
                parameters=[*_params_files("sim"), use_sim_time, scenario],
            ),
            Node(
                package=PACKAGE,
                executable="scene_encoder",
                name="scene_encoder",
                output="screen",
                parameters=[*_params_files("scene_encoder"), use_sim_time],
            ),
            Node(
                package=PACKAGE,
                executable="planner",
                name="planner",
                output="screen",
                # the one execution source of this suite (planners start disabled: docs/nodes.md)
                parameters=[*_params_files("planner"), use_sim_time, {"enabled": True}],
            ),
        ]
    )
