"""The view's ROS-free parts: link colours, cloud colours, robot mesh poses against the arm's kinematics."""

from __future__ import annotations

import numpy as np
import pytest

from latent_planner_ros.robot.panda import load_panda
from latent_planner_ros.view.robot_meshes import robot_meshes
from latent_planner_ros.view.scene import COLLISION_RGB, ROBOT_RGB, collision_rgb, height_colors


def test_collision_colour_runs_from_the_robot_grey_to_red_and_clamps():
    assert collision_rgb(0.0) == ROBOT_RGB and collision_rgb(1.0) == COLLISION_RGB
    assert collision_rgb(-3.0) == ROBOT_RGB and collision_rgb(7.0) == COLLISION_RGB
    assert collision_rgb(float("nan")) == ROBOT_RGB
    mid = collision_rgb(0.5)
    assert all(min(a, b) <= m <= max(a, b) for a, b, m in zip(ROBOT_RGB, COLLISION_RGB, mid, strict=True))


def test_height_colours_are_per_point_and_ordered_by_height():
    pts = np.array([[0, 0, -1.0], [0, 0, 0.1], [0, 0, 2.0]])
    c = height_colors(pts)
    assert c.shape == (3, 3) and c.dtype == np.uint8
    assert c[0].tolist() == [30, 150, 160] and c[2].tolist() == [250, 220, 60]


def test_mesh_poses_follow_the_kinematics_of_their_links():
    meshes = robot_meshes()
    q = np.array([0.2, 0.3, -0.1, -1.8, 0.4, 1.5, -0.3])
    poses = meshes.poses(q)
    assert set(poses) == {m.name for m in meshes.meshes} and len(poses) >= 9
    panda = load_panda()
    for mesh in meshes.meshes:
        if mesh.name.endswith("_0") and mesh.link.startswith("panda_link"):
            wxyz, xyz = poses[mesh.name]
            frame = panda.fk(q, mesh.link)
            assert xyz == pytest.approx(frame.translation, abs=1e-9)  # STL meshes sit at their link's origin
            assert np.linalg.norm(wxyz) == pytest.approx(1.0)
    wxyz, tcp = meshes.tcp(q)
    assert tcp == pytest.approx(panda.fk(q).translation)


def test_link_probabilities_come_from_the_status_values():
    from latent_planner_ros.view.scene import link_probabilities

    assert link_probabilities({"p_collision_links": "panda_link1=0.010 panda_hand=0.900"}) == {
        "panda_link1": 0.01,
        "panda_hand": 0.9,
    }
    assert link_probabilities({"p_collision": "0.25"}) == 0.25  # the arm's one probability
    assert link_probabilities({"p_collision": "n/a"}) == 0.0 and link_probabilities({}) == 0.0
