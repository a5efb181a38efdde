"""Scenario objects as the project's obstacle primitives (``latent_planner_ros.data.obstacles``), e.g. for
exact collision checks or planners that are given the ground-truth scene.

Primitives keep their pose; mesh vertices are moved from the object frame into ``world`` (the obstacle
schema has no pose for meshes). Moving objects are taken at scenario time t.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from latent_planner_ros.data.obstacles import Obstacle, obstacle_from_dict
from sim_bridge.scenario import SHAPES, Scenario, SceneObject


def object_obstacle(obj: SceneObject, t: float = 0.0) -> Obstacle:
    """The obstacle primitive of one scene object at scenario time t [s]."""
    position = obj.position_at(t)
    if obj.type == "mesh":
        rotation = Rotation.from_quat(obj.quaternion_xyzw).as_matrix()
        vertices = np.asarray(obj.vertices) @ rotation.T + position
        return obstacle_from_dict({"type": "mesh", "vertices": vertices, "faces": obj.faces})
    spec = {"type": obj.type, "position": position, "quaternion_xyzw": obj.quaternion_xyzw}
    spec.update({key: getattr(obj, key) for key in SHAPES[obj.type]})
    return obstacle_from_dict(spec)


def scenario_obstacles(scenario: Scenario, t: float = 0.0) -> list[Obstacle]:
    """Every object of the scenario (not the table) as an obstacle at scenario time t [s]."""
    return [object_obstacle(obj, t) for obj in scenario.objects]
