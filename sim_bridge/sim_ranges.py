"""Valid ranges of SimConfig and CameraConfig fields, for the sim node's parameter descriptors.

In the notation of docs/nodes.md; each is what the config's validation enforces (test/nodes/test_param_ranges.py
probes both ends). Bounds that depend on another field (joint_state_rate <= 1 / timestep, cloud_rate <=
joint_state_rate, max_depth > min_depth) are left to the validation.
"""

from __future__ import annotations

from sim_bridge.camera_config import CameraConfig
from sim_bridge.sim_config import SimConfig

SIM = {
    "seed": "[-1, 2147483647]",
    "timestep": "[0.0001, 0.01]",
    "real_time_factor": "[0, 1000]",
    "command_period": "[0, 5]",
    "command_timeout": "[0, 3600]",
    "velocity_scale": "(0, 1]",
}

CAMERA = {
    "width": "[8, 1280]",
    "height": "[8, 960]",
    "fovy": "[1, 170]",
    "stride": "[1, 64]",
    "voxel_size": "[0, 1]",
    "depth_noise": "[0, 1]",
    "dropout": "[0, 0.99]",
    "rate": "[0, 100]",
}

SIM_RANGES = {SimConfig: SIM, CameraConfig: CAMERA}
"""{config class: {field: range}} of the sim's configs."""

SIM_READ_ONLY = ("cameras",)
"""The camera list is fixed at start-up (one publisher pair per camera)."""
