"""Names of the command-line entry points, as "module:function" strings.

No imports here: setup.py reads this file to install the node executables.
Node functions take no arguments (they read sys.argv, with ROS arguments); train and bench
functions take an argv list and return an exit code.
"""

NODES = {
    "robot_info": "latent_planner_ros.nodes.robot_info:main",
    "scene_encoder": "latent_planner_ros.nodes.scene_encoder:main",
    "sim": "sim_bridge.node:main",
    "planner": "latent_planner_ros.nodes.planner:main",
    "ompl_planner": "latent_planner_ros.nodes.ompl_planner:main",
}

TRAIN = {
    "collision": "latent_planner_ros.training.train_collision:main",
    "distil": "latent_planner_ros.training.distil_collision:main",
    "local-collision": "latent_planner_ros.training.train_local_collision:main",
    "lspp": "latent_planner_ros.training.train_lspp:main",
    "vae": "latent_planner_ros.training.train_vae:main",
}

BENCH = {
    "background": "latent_planner_ros.bench.background:main",
    "collision": "latent_planner_ros.bench.collision:main",
    "conveyor": "latent_planner_ros.bench.conveyor:main",
    "faults": "latent_planner_ros.bench.faults:main",
    "fuzz": "latent_planner_ros.bench.fuzz:main",
    "lspp": "latent_planner_ros.bench.lspp:main",
    "planner": "latent_planner_ros.bench.planner:main",
    "profile": "latent_planner_ros.bench.profile:main",
    "reach": "latent_planner_ros.bench.reach:main",
    "robot": "latent_planner_ros.bench.robot:main",
    "sim": "latent_planner_ros.bench.sim:main",
    "soak": "latent_planner_ros.bench.soak:main",
    "table": "latent_planner_ros.bench.table:main",
    "vae": "latent_planner_ros.bench.vae:main",
}
