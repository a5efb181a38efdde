"""The viser scene of the suite: robot, commanded robot, clouds, target, goal gizmo, paths, obstacles, status and
controls. No ROS: nodes/view.py feeds it numpy arrays and wires the controls to topics and services.

Scene names (the page's scene tree; the browser test looks for them):
``/robot/<mesh>`` the arm at the measured joint states, ``/command/<mesh>`` the commanded state (translucent),
``/clouds/<topic>`` each cloud, ``/target`` the sim's target, ``/goal`` the goal gizmo, ``/paths/<name>`` TCP
paths, ``/obstacles/<key>`` cylinders and spheres of the markers.

    scene = SuiteScene(viser.ViserServer(port=8080))
    scene.set_joint_state(q)                  # (7,) [rad]
    scene.set_cloud("camera/points", xyz)     # (N, 3) [m] in world
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from latent_planner_ros.view.robot_meshes import robot_meshes

ROBOT_RGB = (200, 200, 210)
COLLISION_RGB = (230, 40, 30)
COMMAND_RGB = (80, 160, 255)
STILL_RAD = 1e-4
"""[rad] joint change below which the arm's meshes are not sent again"""
MAX_CLOUD_POINTS = 60_000
"""clouds above this are subsampled (every k-th point) before they are sent to the page"""


def collision_rgb(p: float) -> tuple[int, int, int]:
    """The colour of a link with collision probability p in [0, 1]: the robot's grey (0) to red (1)."""
    p = float(np.clip(p if np.isfinite(p) else 0.0, 0.0, 1.0))
    return tuple(int(round(a + (b - a) * p)) for a, b in zip(ROBOT_RGB, COLLISION_RGB, strict=True))


def height_colors(points: np.ndarray, z_lo: float = 0.0, z_hi: float = 0.25) -> np.ndarray:
    """(N, 3) uint8 colours of points (N, 3) [m] by height: teal at `z_lo` to yellow at `z_hi`."""
    t = np.clip((points[:, 2] - z_lo) / (z_hi - z_lo), 0.0, 1.0)[:, None]
    lo, hi = np.array([30, 150, 160]), np.array([250, 220, 60])
    return (lo + (hi - lo) * t).astype(np.uint8)


def link_probabilities(values: dict[str, str]) -> dict[str, float] | float:
    """The collision probabilities in a planner status: {link: p} from ``p_collision_links`` ("link=p link=p ..."),
    else the arm's one ``p_collision`` (0.0 when neither is there or readable)."""
    links = {}
    for item in values.get("p_collision_links", "").split():
        name, _, p = item.partition("=")
        try:
            links[name] = float(p)
        except ValueError:
            continue
    if links:
        return links
    try:
        return float(values.get("p_collision", "0") or 0.0)
    except ValueError:
        return 0.0


@dataclass(frozen=True)
class Shape:
    """An obstacle or marker to draw: kind "cylinder" (scale = diameter x, y, height z), "sphere" or "line"."""

    kind: str
    position: np.ndarray
    wxyz: np.ndarray
    scale: np.ndarray
    rgb: tuple[int, int, int]
    points: np.ndarray | None = None


class SuiteScene:
    """Builds and updates the scene on a viser server (see the module docstring).

    Args:
        server: the viser server.
        on_goal: called with (position (3,) [m], wxyz (4,)) when the user moves the goal (gizmo or the goal fields).
        on_enable: called with True/False when the user switches the planner.
    """

    def __init__(
        self,
        server,
        on_goal: Callable[[np.ndarray, np.ndarray], None] | None = None,
        on_enable: Callable[[bool], None] | None = None,
    ):
        self.server = server
        self.on_goal, self.on_enable = on_goal, on_enable
        self._lock = threading.Lock()
        self.meshes = robot_meshes()
        scene, gui = server.scene, server.gui
        scene.set_up_direction("+z")
        server.initial_camera.position = (1.45, -1.05, 0.85)
        server.initial_camera.look_at = (0.4, 0.0, 0.2)
        scene.add_grid("/table", width=2.0, height=2.0, cell_size=0.1, position=(0.3, 0.0, 0.0))
        self._robot = {
            m.name: scene.add_mesh_simple(f"/robot/{m.name}", m.vertices, m.faces, color=ROBOT_RGB, visible=False)
            for m in self.meshes.meshes
        }
        self._command = {
            m.name: scene.add_mesh_simple(
                f"/command/{m.name}", m.vertices, m.faces, color=COMMAND_RGB, opacity=0.3, visible=False
            )
            for m in self.meshes.meshes
        }
        self._clouds: dict[str, object] = {}
        self._paths: dict[str, object] = {}
        self._shapes: dict[str, object] = {}
        self._target = scene.add_frame("/target", axes_length=0.08, axes_radius=0.004, visible=False)
        self._goal_seen = scene.add_frame("/goal_received", axes_length=0.05, axes_radius=0.006, visible=False)
        self._gizmo = scene.add_transform_controls("/goal", scale=0.18, position=(0.45, 0.0, 0.4), visible=True)
        self._gizmo.on_update(lambda _: self._gizmo_moved())
        self.paused = False
        self._last_q: dict[int, np.ndarray] = {}

        with gui.add_folder("Planner"):
            self.status_md = gui.add_markdown("*no planner status yet*")
            self.enabled = gui.add_checkbox("Planner enabled", initial_value=False)
            self.enabled.on_update(self._enable_clicked)
        with gui.add_folder("Goal"):
            self.goal_x = gui.add_number("goal x", initial_value=0.45, step=0.01)
            self.goal_y = gui.add_number("goal y", initial_value=0.0, step=0.01)
            self.goal_z = gui.add_number("goal z", initial_value=0.4, step=0.01)
            self.send_goal = gui.add_button("Send goal")
            self.send_goal.on_click(lambda _: self._fields_sent())
        with gui.add_folder("View"):
            self.pause = gui.add_checkbox("Pause", initial_value=False)
            self.pause.on_update(lambda _: setattr(self, "paused", bool(self.pause.value)))
            self.info_md = gui.add_markdown("")

    # -- controls ------------------------------------------------------------------------------------
    def _enable_clicked(self, event) -> None:
        if event.client is not None and self.on_enable is not None:  # not our own sync from the status
            self.on_enable(bool(self.enabled.value))

    def _gizmo_moved(self) -> None:
        pos, wxyz = np.array(self._gizmo.position, dtype=float), np.array(self._gizmo.wxyz, dtype=float)
        for field, value in zip((self.goal_x, self.goal_y, self.goal_z), pos, strict=True):
            field.value = round(float(value), 4)
        if self.on_goal is not None:
            self.on_goal(pos, wxyz)

    def _fields_sent(self) -> None:
        pos = np.array([self.goal_x.value, self.goal_y.value, self.goal_z.value], dtype=float)
        self._gizmo.position = tuple(pos)
        if self.on_goal is not None:
            self.on_goal(pos, np.array(self._gizmo.wxyz, dtype=float))

    def place_goal(self, position: np.ndarray, wxyz: np.ndarray) -> None:
        """Move the gizmo and the goal fields (e.g. to the TCP at start-up) without sending a goal."""
        self._gizmo.position, self._gizmo.wxyz = tuple(map(float, position)), tuple(map(float, wxyz))
        for field, value in zip((self.goal_x, self.goal_y, self.goal_z), position, strict=True):
            field.value = round(float(value), 4)

    # -- inputs ------------------------------------------------------------------------------------
    def _pose_meshes(self, handles: dict, q: np.ndarray) -> None:
        key = id(handles)
        last = self._last_q.get(key)
        if last is not None and np.max(np.abs(last - q)) < STILL_RAD:
            return  # the arm has not moved: nothing to send
        self._last_q[key] = np.array(q, dtype=float)
        with self.server.atomic():
            for name, (wxyz, xyz) in self.meshes.poses(q).items():
                handle = handles[name]
                handle.wxyz, handle.position = wxyz, xyz
                if not handle.visible:
                    handle.visible = True

    def set_joint_state(self, q: np.ndarray) -> None:
        """The measured arm configuration q (7,) [rad]."""
        if not self.paused:
            self._pose_meshes(self._robot, q)

    def set_command(self, q: np.ndarray) -> None:
        """The commanded configuration q (7,) [rad] (drawn translucent)."""
        if not self.paused:
            self._pose_meshes(self._command, q)

    def set_link_collision(self, p: dict[str, float] | float) -> None:
        """Colour the links by collision probability: {link name: p} or one p for the whole arm."""
        for mesh in self.meshes.meshes:
            value = p if isinstance(p, float) else p.get(mesh.link, 0.0)
            rgb = collision_rgb(value)
            if tuple(self._robot[mesh.name].color) != rgb:
                self._robot[mesh.name].color = rgb

    def set_cloud(self, name: str, points: np.ndarray) -> None:
        """A cloud (N, 3) [m] in world, shown under /clouds/<name>, coloured by height."""
        if self.paused:
            return
        points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        points = points[np.all(np.isfinite(points), axis=1)]
        if len(points) > MAX_CLOUD_POINTS:
            points = points[:: int(np.ceil(len(points) / MAX_CLOUD_POINTS))]
        if not len(points):
            points = np.zeros((1, 3), dtype=np.float32)
        colors = height_colors(points)
        handle = self._clouds.get(name)
        if handle is None:
            self._clouds[name] = self.server.scene.add_point_cloud(
                f"/clouds/{name}", points, colors, point_size=0.008, point_shape="circle", precision="float32"
            )
        else:
            with self.server.atomic():
                handle.points, handle.colors = points, colors

    def set_target(self, position: np.ndarray, wxyz: np.ndarray) -> None:
        """The sim's target pose (position [m], wxyz) in world."""
        if not self.paused:
            self._target.position, self._target.wxyz, self._target.visible = tuple(position), tuple(wxyz), True

    def set_goal_received(self, position: np.ndarray, wxyz: np.ndarray) -> None:
        """The goal the planner was last sent on goal_pose (by anyone)."""
        if not self.paused:
            self._goal_seen.position, self._goal_seen.wxyz, self._goal_seen.visible = (
                tuple(position),
                tuple(wxyz),
                True,
            )

    def set_path(self, name: str, points: np.ndarray, rgb: tuple[int, int, int] = (255, 140, 0)) -> None:
        """A TCP path (T, 3) [m] as a polyline under /paths/<name> (fewer than 2 points: hidden)."""
        if self.paused:
            return
        old = self._paths.pop(name, None)
        if old is not None:
            old.remove()
        points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        if len(points) >= 2:
            segments = np.stack([points[:-1], points[1:]], axis=1)
            self._paths[name] = self.server.scene.add_line_segments(
                f"/paths/{name}", segments, colors=rgb, line_width=3.0
            )

    def set_shapes(self, shapes: dict[str, Shape]) -> None:
        """Replace the drawn obstacles/markers by `shapes` ({key: Shape})."""
        if self.paused:
            return
        for key in list(self._shapes):
            if key not in shapes:
                self._shapes.pop(key).remove()
        scene = self.server.scene
        for key, s in shapes.items():
            old = self._shapes.pop(key, None)
            if old is not None:
                old.remove()
            name = f"/obstacles/{key}"
            if s.kind == "cylinder":
                self._shapes[key] = scene.add_cylinder(
                    name,
                    radius=float(s.scale[0]) / 2,
                    height=float(s.scale[2]),
                    color=s.rgb,
                    opacity=0.6,
                    position=tuple(s.position),
                    wxyz=tuple(s.wxyz),
                )
            elif s.kind == "sphere":
                self._shapes[key] = scene.add_icosphere(
                    name, radius=float(s.scale[0]) / 2, color=s.rgb, position=tuple(s.position)
                )
            elif s.kind == "line" and s.points is not None and len(s.points) >= 2:
                seg = np.stack([s.points[:-1], s.points[1:]], axis=1).astype(np.float32)
                self._shapes[key] = scene.add_line_segments(name, seg, colors=s.rgb, line_width=3.0)

    def set_status(self, values: dict[str, str], level: int = 0) -> None:
        """The planner's status (its DiagnosticStatus values) as text; colours the links by `p_collision_links`
        (else the whole arm by `p_collision`)."""
        keys = ("state", "mode", "command_source", "tick_ms", "p_collision", "pos_err_m", "cloud_points_used")
        lines = [f"**{k}**: {values[k]}" for k in keys if k in values]
        if values.get("last_error"):
            lines.append(f"**last error**: {values['last_error']}")
        if level >= 2:
            lines.insert(0, "**ERROR**")
        self.status_md.content = "  \n".join(lines) or "*empty status*"
        if "state" in values:
            self.enabled.value = values["state"] != "disabled"
        self.set_link_collision(link_probabilities(values))

    def set_info(self, text: str) -> None:
        """A line under the view's controls (rates, counts)."""
        self.info_md.content = text
