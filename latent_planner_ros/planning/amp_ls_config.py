"""Configuration of the AMP-LS planner (seed chapter 7, Algorithm 1; GECO as in appendix 6.B.1)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

BACKENDS = ("learned", "geometric", "cylinders", "none")


@dataclass
class AmpLsConfig:
    """Every field maps 1:1 onto a ROS parameter of the planner node."""

    lr: float = 0.06
    """latent step size (Adam learning rate) of the closed loop (`step`) [latent units]"""
    plan_lr: float = 0.3
    """latent step size of open-loop plans (`plan`) [latent units] (the seed's single step size: lr)"""
    optimizer: str = "adam"
    """"adam" or "sgd" (plain gradient step, seed eq. 3)"""
    max_steps: int = 600
    """optimisation step budget of one open-loop plan"""
    pos_tol: float = 0.01
    """position tolerance [m]"""
    ori_tol_deg: float = 15.0
    """orientation tolerance [deg]"""
    use_collision: bool = True
    """collision loss and explicit collision checking (ablation: False)"""
    use_prior: bool = True
    """prior loss -log p(z) (ablation: False)"""
    use_orientation: bool = True
    """orientation loss and tolerance (False: position only)"""
    collision_backend: str = "learned"
    """"learned" (scene embedding + collision predictor), "geometric" (spheres vs cloud), "cylinders" (LSPP: the
    obstacle classifier on state-based cylinders) or "none\""""
    col_threshold: float = 0.2
    """gamma_col: a decoded state with p(collision) above this is not accepted"""
    backtrace_keep: float = 0.0
    """fraction of the collision-free part of a colliding step kept on the path when back-tracing, z moving
    along with it (beyond the seed); 0 = the seed: back to the last accepted state"""
    interp_steps: int = 15
    """m: states checked on the linear interpolation of each accepted step"""
    check_step_rad: float = 0.02
    """> 0: check one interpolated state per this joint-space step [rad] instead of a fixed interp_steps
    (short steps cost fewer checks, long ones get more; beyond the seed); 0: the seed's fixed m"""
    lazy_check: bool = True
    """open loop: hard-check a seed's accepted steps only once it reaches the goal (and the chosen seed's at the
    end), in one batch, back-tracing to the state before the first colliding step (beyond the seed: seeds that
    never win are not checked; about 3x faster at the same success in `bench table`); False: every step is
    checked as it is accepted (the seed, and always in the closed loop)"""
    finish_radius_m: float = 2.0
    """open loop: > 0 lets the seed nearest the goal, once its TCP is within this distance [m] and
    finish_angle_deg of the goal, finish by exact damped-least-squares IK from its accepted state, the straight
    segment to the solution checked like any step (beyond the seed); 0: only the latent optimisation reaches"""
    finish_angle_deg: float = 180.0
    """orientation error [deg] within which the exact finish is tried"""
    finish_max_rad: float = 3.0
    """largest joint change [rad] the exact finish may make"""
    finish_ik_iters: int = 50
    """damped-least-squares iterations of one exact-finish attempt"""
    finish_ik_step_rad: float = 0.3
    """largest joint change [rad] of one of those iterations"""
    finish_ik_stall: int = 12
    """an exact-finish attempt gives up once its position and orientation errors have not dropped below 0.99 of
    their best for this many iterations (ik.stall_iters); 0: it runs all finish_ik_iters"""
    direct_first: bool = True
    """open loop, with the exact finish and `shortcut` on: before the first optimisation step, run the exact
    finish's IK from the start itself and try the straight segment to its solution (beyond the seed: a goal
    reachable in a straight line is taken without optimising; otherwise the plan goes on as without it)"""
    finish_every: int = 2
    """iterations between two exact-finish attempts of one seed"""
    escape_rad: float = 0.05
    """open loop: when the start itself fails the hard check (the arm's conservative spheres touch cloud points,
    a noisy point), states within this max-joint distance [rad] of the start are not refused, so the arm can
    move out; 0: refused (the plan then cannot accept a step)"""
    goal_guidance: int = 4
    """open loop: at the first restart, look for up to this many distinct IK solutions of the goal that pass the
    hard check (damped least squares from several seeds, as the OMPL baseline does); restarted seeds then take
    the joint-space distance to one of them as their target loss and (with the exact finish on) finish by the
    straight segment to it once within finish_max_rad (beyond the seed: goals that need joints near their limits
    stall the pose loss); 0: restarts keep the pose target"""
    rrt_escape_budget_s: float = 1.0
    """open loop: when the latent search ends without the goal (every seed stalled, the step budget spent, or
    rrt_escape_after_s passed), OMPL's RRTConnect searches joint space for at most this long [s], goal IK included,
    from the start to goal configurations (as goal_guidance finds them, at least one), every state and motion on
    the same hard check as the accepted steps, and the path is shortcut (planning/escape.py; beyond the seed: the
    latent optimisation is local and stalls in bins, under shelves and behind walls); 0: off"""
    rrt_escape_after_s: float = 0.25
    """open loop: wall time [s] of the latent search (from the start of the plan) after which the RRT escape
    runs (with rrt_escape_budget_s > 0); if it finds no path, the latent search goes on to its own end"""
    timeout_s: float = 5.0
    """open loop: give a plan up after this wall time [s] (checked after each step; the RRT escape's budget is
    spent within it), as RRTConnect's 5 s; 0: the step budget alone (LSPP, whose plans take 5-8 s)"""
    geometric_retry: bool = True
    """open loop, learned backend: a plan that fails with the network is planned again with the geometric
    backend on the same cloud, within what is left of timeout_s (the network has learned tabletops; a scene
    unlike them, e.g. furniture in front of the robot, can defeat it where the exact check does not)"""
    shortcut: bool = True
    """open loop: shorten a successful path by straight joint-space shortcuts that pass the same hard check as
    the accepted steps (planning/shortcut.py; beyond the seed); with lazy_check, a seed reaching the goal first
    tries the straight segment from the start, before its own steps are checked"""
    self_check: bool = True
    """also check every interpolated state for self- and table collision (exact checks of the
    convex hulls of the link meshes, which contain the meshes; beyond the seed)"""
    target_on_fk: bool = True
    """target losses on the exact torch FK of the decoded q instead of the decoded pose"""
    n_seeds: int = 8
    """latent seeds optimised together (the first to reach the goal wins); 1 = the seed's single trajectory"""
    closed_loop_seeds: int = 1
    """latent seeds of the closed-loop `step` (each tick checks every seed's step: the tick time grows with it)"""
    seed_noise: float = 1.0
    """std of the perturbation of the extra seeds around the encoded start [latent units]"""
    lambda_pos: float = 1.0
    """initial weight of the position loss [1/m]"""
    lambda_ori: float = 0.3
    """initial weight of the orientation loss"""
    lambda_col: float = 1.0
    """initial weight of the collision loss"""
    tau_prior: float = 1.5
    """GECO target of the prior loss 0.5 * mean(z^2): lambda_pos and lambda_ori grow while the prior loss is
    below it and shrink while above (the seed's lambda_prior, appendix 6.B.1, moved onto the target terms)"""
    tau_col: float = 0.1
    """GECO target of the collision loss -log(1 - p): lambda_col grows while the loss is above it"""
    geco_alpha_ma: float = 0.9
    """GECO moving-average factor"""
    geco_step_target: float = 0.05
    """GECO learning rate of lambda_pos / lambda_ori"""
    geco_step_col: float = 0.05
    """GECO learning rate of lambda_col"""
    lambda_min: float = 1e-3
    """smallest value a GECO multiplier (lambda_pos, lambda_ori, lambda_col) may take"""
    lambda_max: float = 1e3
    """largest value a GECO multiplier may take"""
    patience: int = 60
    """stop with "no progress" after this many steps without 2 mm of improvement"""
    restarts: int = 8
    """open loop: a seed stalled for `patience` steps restarts from the best seed's last accepted state plus
    seed_noise * restart_scale of latent noise, up to this many times in total (0 = the seed's behaviour)"""
    restart_scale: float = 1.0
    """latent kick of a restart, in multiples of seed_noise"""
    speed_scale: float = 0.5
    """fraction of the joint velocity limits used by the time parameterisation"""

    def __post_init__(self) -> None:
        problems = []
        if self.optimizer not in ("adam", "sgd"):
            problems.append(f"optimizer must be 'adam' or 'sgd', got {self.optimizer!r}")
        if self.collision_backend not in BACKENDS:
            problems.append(f"collision_backend must be one of {BACKENDS}, got {self.collision_backend!r}")
        positive = (
            "lr",
            "plan_lr",
            "pos_tol",
            "ori_tol_deg",
            "seed_noise",
            "speed_scale",
            "restart_scale",
            "finish_ik_step_rad",
        )
        for name in (*positive, "lambda_min", "lambda_max"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                problems.append(f"{name} must be a positive finite number, got {v!r}")
        if not (isinstance(self.backtrace_keep, int | float) and 0.0 <= self.backtrace_keep < 1.0):
            problems.append(f"backtrace_keep must be in [0, 1), got {self.backtrace_keep!r}")
        if not (isinstance(self.restarts, int) and self.restarts >= 0):
            problems.append(f"restarts must be an integer >= 0, got {self.restarts!r}")
        for name in (
            "finish_radius_m",
            "finish_angle_deg",
            "finish_max_rad",
            "escape_rad",
            "rrt_escape_budget_s",
            "rrt_escape_after_s",
            "timeout_s",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                problems.append(f"{name} must be a finite number >= 0, got {v!r}")
        for name in ("goal_guidance", "finish_ik_stall"):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
                problems.append(f"{name} must be an integer >= 0, got {v!r}")
        for name in (
            "max_steps",
            "interp_steps",
            "finish_every",
            "finish_ik_iters",
            "n_seeds",
            "closed_loop_seeds",
            "patience",
        ):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 1):
                problems.append(f"{name} must be an integer >= 1, got {getattr(self, name)!r}")
        if not (isinstance(self.check_step_rad, int | float) and 0.0 <= self.check_step_rad <= 0.5):
            problems.append(f"check_step_rad must be in [0, 0.5], got {self.check_step_rad!r}")
        if not 0.0 < self.col_threshold < 1.0:
            problems.append(f"col_threshold must be in (0, 1), got {self.col_threshold}")
        if not 0.0 <= self.geco_alpha_ma < 1.0:
            problems.append(f"geco_alpha_ma must be in [0, 1), got {self.geco_alpha_ma}")
        if self.speed_scale > 1.0:
            problems.append(f"speed_scale must be <= 1, got {self.speed_scale}")
        if problems:
            raise ValueError("; ".join(problems))

    @property
    def ori_tol(self) -> float:
        return math.radians(self.ori_tol_deg)

    def to_dict(self) -> dict:
        return asdict(self)
