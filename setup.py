"""ament_python package: installs with pip, and with colcon for `ros2 run`."""

import os
import runpy
from glob import glob

from setuptools import find_packages, setup

PACKAGE = "latent_planner_ros"

# Node executables: `ros2 run latent_planner_ros <name>` after colcon build (setup.cfg puts them in
# lib/latent_planner_ros), `python -m latent_planner_ros run <name>` after pip install.
NODES = runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), PACKAGE, "registry.py"))["NODES"]

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(
        include=[PACKAGE, f"{PACKAGE}.*", "sim_bridge", "sim_bridge.*", "msg_adapters", "msg_adapters.*"]
    ),
    # The MJCF models stay inside sim_bridge (sim_bridge/mjcf.py loads them next to itself; scene.xml includes
    # robot.xml relative to its own file).
    package_data={"sim_bridge": ["models/*.xml"]},
    # Shipped data (weights, benchmark scenario sets, node and scenario YAMLs) goes to share/latent_planner_ros
    # only, as ROS tools expect (ament index, `ros2 pkg prefix --share`, FindPackageShare), one 13 MB copy per
    # install; latent_planner_ros/resources.py finds it there, or in the source tree for editable and
    # --symlink-install builds. A pip wheel puts data_files under its prefix too, so pip installs find it the same
    # way.
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/config/scenarios", glob("config/scenarios/*.yaml")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        (
            f"share/{PACKAGE}/checkpoints",
            glob(f"{PACKAGE}/checkpoints/*.safetensors") + glob(f"{PACKAGE}/checkpoints/*.json"),
        ),
        (f"share/{PACKAGE}/bench/scenarios", glob(f"{PACKAGE}/bench/scenarios/*.json")),
    ],
    install_requires=["setuptools"],
    # Ray for running the batch commands on a cluster (--cluster; docs/cluster.md), imported only then.
    extras_require={"cluster": ["ray==2.60.0"]},
    zip_safe=False,
    maintainer="latent_planner_ros maintainers",
    maintainer_email="maintainers@latent-planner.dev",
    description="Learned latent-space motion planning for the Franka Panda on ROS 2 (AMP-LS, LSPP).",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [f"latent-planner = {PACKAGE}.cli:main"]
        + [f"{name} = {target}" for name, target in NODES.items()],
    },
)
