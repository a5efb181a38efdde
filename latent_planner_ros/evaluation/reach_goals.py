"""Goals for static reaching in the sim's scenarios. No ROS.

A scenario file with a target (e.g. ``shelf``) gives its own goal. Otherwise (``tabletop``) a goal is drawn:
feasible configurations (joint limits, no self or table collision) whose TCP points down (within
`max_tilt_deg`), lies in a box over the objects and is at least `min_travel_m` from the start's TCP, with a
clearance of at least `min_clearance_m` between the arm and the scenario objects (MuJoCo's geom distance in
the scene the sim builds). Among those, the goal nearest to the objects wins, so the obstacles matter.
The draw depends only on the scenario, its seed and `goal_seed`, so every run poses the same problem.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.rotations import matrix_to_quat

GOAL_BOX = ((0.3, -0.45, 0.06), (0.75, 0.45, 0.35))
"""[m] (lower, upper) corners in `world` of the region drawn goals lie in."""


@dataclass(frozen=True)
class ReachGoal:
    """A static reaching problem in a sim scenario.

    Attributes:
        scenario: scenario name or file (the sim's `scenario` parameter); seed: its `seed` parameter.
        position: (3,) TCP target [m] in `world`; quaternion_xyzw: (4,) its orientation.
        q_goal: (7,) a configuration reaching it [rad] (None for a scenario's own target); never given to planners.
        clearance_m: the arm's clearance to the objects at q_goal [m] (None for a scenario's own target).
    """

    scenario: str
    seed: int
    position: np.ndarray
    quaternion_xyzw: np.ndarray
    q_goal: np.ndarray | None = None
    clearance_m: float | None = None

    def to_dict(self) -> dict:
        return {
            "scenario": self.scenario,
            "seed": self.seed,
            "position": [round(float(v), 5) for v in self.position],
            "quaternion_xyzw": [round(float(v), 5) for v in self.quaternion_xyzw],
            "q_goal": None if self.q_goal is None else [round(float(v), 5) for v in self.q_goal],
            "clearance_m": self.clearance_m,
        }


def arm_clearance(sim, q: np.ndarray) -> float:
    """The arm's clearance [m] to the scenario objects of a `sim_bridge.sim.Sim` with the arm put at q (7,) [rad].

    Only the kinematic state is set (no physics step); call on a Sim used for geometry queries only.
    """
    import mujoco

    sim.data.qpos[:7] = np.asarray(q, dtype=float)
    mujoco.mj_forward(sim.model, sim.data)
    return sim.nearest_object()[0]


def choose_goal(
    scenario: str,
    seed: int,
    goal_seed: int = 0,
    candidates: int = 4000,
    min_clearance_m: float = 0.05,
    max_tilt_deg: float = 30.0,
    min_travel_m: float = 0.25,
) -> ReachGoal:
    """The goal of `scenario` with `seed`: its own target, else a drawn one (see the module docstring).

    Raises:
        ValueError: no drawn configuration passes the filters.
    """
    from latent_planner_ros.robot.panda import load_panda
    from latent_planner_ros.robot.sampler import FeasibleSampler
    from sim_bridge.scenario_files import load_scenario
    from sim_bridge.sim import Sim

    scene = load_scenario(scenario, seed=seed)
    if scene.target is not None and scene.target.object is None:
        target = scene.target_pose_at(0.0)
        return ReachGoal(scenario, seed, np.asarray(target[0]), np.asarray(target[1]))
    panda = load_panda()
    q = FeasibleSampler(np.random.default_rng([seed, goal_seed]), table=True).sample(candidates)
    pos, rot = panda.fk_batch(q)
    down = -rot[:, 2, 2] >= np.cos(np.radians(max_tilt_deg))  # TCP z axis against world -z
    lo, hi = (np.asarray(c) for c in GOAL_BOX)
    inside = np.all((pos >= lo) & (pos <= hi), axis=1)
    far = np.linalg.norm(pos - panda.fk(Q_READY).translation, axis=1) >= min_travel_m
    keep = np.flatnonzero(down & inside & far)
    if keep.size == 0:
        raise ValueError(f"{scenario} seed {seed}: no goal candidate in {GOAL_BOX} pointing down")
    sim = Sim(scene)
    try:
        clearances = np.array([arm_clearance(sim, q[k]) for k in keep])
    finally:
        sim.close()
    ok = clearances >= min_clearance_m
    if not ok.any():
        raise ValueError(f"{scenario} seed {seed}: no goal candidate with {min_clearance_m} m of clearance")
    best = keep[ok][np.argmin(clearances[ok])]
    return ReachGoal(
        scenario,
        seed,
        pos[best],
        matrix_to_quat(rot[best]),
        q_goal=q[best],
        clearance_m=float(clearances[ok].min()),
    )
