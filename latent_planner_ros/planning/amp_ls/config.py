"""Configuration of AMP-LS: the seed's algorithm at the top (chapter 7, Algorithm 1; GECO as in appendix 6.B.1),
one sub-configuration per part beyond the seed. A part that is off is `None`.

    AmpLsConfig()                          # this project's default (presets.default())
    presets.seed()                         # the seed's AMP-LS: one trajectory, eager checks, no extra parts
    replace(cfg, finish=None)              # one part off
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace

BACKENDS = ("learned", "geometric", "local", "cylinders", "none")


def _problems(obj, positive=(), non_negative=(), at_least_one=(), counts=()) -> list[str]:
    """Range problems of obj's fields: positive finite numbers, finite numbers >= 0, integers >= 1, integers >= 0."""
    out = []
    for name in positive:
        v = getattr(obj, name)
        if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
            out.append(f"{name} must be a positive finite number, got {v!r}")
    for name in non_negative:
        v = getattr(obj, name)
        if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v >= 0):
            out.append(f"{name} must be a finite number >= 0, got {v!r}")
    for name in at_least_one:
        v = getattr(obj, name)
        if not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
            out.append(f"{name} must be an integer >= 1, got {v!r}")
    for name in counts:
        v = getattr(obj, name)
        if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
            out.append(f"{name} must be an integer >= 0, got {v!r}")
    return out


def _raise(prefix: str, problems: list[str]) -> None:
    if problems:
        raise ValueError("; ".join(f"{prefix}{p}" for p in problems))


@dataclass
class SearchConfig:
    """The latent search (`search.LatentSearch`): several latent seeds optimised together, restarts of stalled
    seeds (beyond the seed; n_seeds = 1 and restarts = 0 is the seed's single trajectory)."""

    n_seeds: int = 8
    """latent seeds optimised together in a plan (the first to reach the goal wins)"""
    closed_loop_seeds: int = 1
    """latent seeds of the closed-loop `step` (each tick checks every seed's step: the tick time grows with it)"""
    seed_noise: float = 1.0
    """std of the perturbation of the extra seeds around the encoded start [latent units]"""
    plan_lr: float = 0.3
    """latent step size of open-loop plans (`plan`) [latent units]; the closed loop takes the seed's `lr`. 0.6 was
    faster on the generator's training splits at the same success (docs/benchmark.md) but, on the held-out sets,
    gave longer paths and 5 unsafe plans against 3 (two of them latent paths, in walls seen edge-on): kept at 0.3;
    `bench table --amp-ls-set search.plan_lr=0.6` measures the other choice"""
    patience: int = 60
    """a seed that has not improved by 2 mm for this many steps has stalled; all stalled: "no progress\""""
    restarts: int = 8
    """open loop: a stalled seed restarts from the best seed's last accepted state plus seed_noise *
    restart_scale of latent noise, up to this many times in total (0 = the seed's behaviour)"""
    restart_scale: float = 1.0
    """latent kick of a restart, in multiples of seed_noise"""
    target_on_fk: bool = True
    """target losses on the exact torch FK of the decoded q instead of the decoded pose (plain decoder only; the
    kinematic decoder is FK by construction)"""

    def __post_init__(self) -> None:
        _raise(
            "search.",
            _problems(
                self,
                positive=("seed_noise", "plan_lr", "restart_scale"),
                at_least_one=("n_seeds", "closed_loop_seeds", "patience"),
                counts=("restarts",),
            ),
        )


MIN_CHECK_STEP_RAD = 0.001
"""finest check step [rad] (a step of 1 rad then takes 1000 checked states, not billions)"""


@dataclass
class CheckConfig:
    """The segment checker (`checker.SegmentChecker`): the hard check of interpolated steps."""

    check_step_rad: float = 0.02
    """> 0: check one interpolated state per this joint-space step [rad] instead of the seed's fixed
    interp_steps (short steps cost fewer checks, long ones get more); 0: the seed's fixed m"""
    lazy: bool = True
    """open loop: hard-check a seed's accepted steps only once it reaches the goal, in one batch, back-tracing to
    the state before the first colliding step (seeds that never win are never checked); False: every step is
    checked as it is accepted (the seed, and always in the closed loop)"""
    backtrace_keep: float = 0.0
    """fraction of the collision-free part of a colliding step kept on the path when back-tracing, z moving
    along with it; 0 = the seed: back to the last accepted state"""
    self_check: bool = True
    """also check every interpolated state for self- and table collision (exact checks of the convex hulls of
    the link meshes)"""
    escape_rad: float = 0.05
    """open loop: when the start itself fails the hard check (the arm's conservative spheres touch cloud points,
    a noisy point), states within this max-joint distance [rad] of the start are not refused, so the arm can
    move out; 0: refused (the plan then cannot accept a step)"""

    def __post_init__(self) -> None:
        problems = _problems(self, non_negative=("escape_rad",))
        step = self.check_step_rad
        if not (isinstance(step, int | float) and (step == 0.0 or MIN_CHECK_STEP_RAD <= step <= 0.5)):
            problems.append(f"check_step_rad must be 0 or in [{MIN_CHECK_STEP_RAD}, 0.5], got {step!r}")
        if not (isinstance(self.backtrace_keep, int | float) and 0.0 <= self.backtrace_keep < 1.0):
            problems.append(f"backtrace_keep must be in [0, 1), got {self.backtrace_keep!r}")
        _raise("checks.", problems)


@dataclass
class FinishConfig:
    """The exact finish (`finish.ExactFinish`, open loop): the seed nearest the goal finishes by damped-least-
    squares IK from its accepted state, the straight segment to the solution checked like any step."""

    radius_m: float = math.inf
    """tried only once the seed's TCP is within this distance [m] of the goal (inf: from the first step on)"""
    angle_deg: float = 180.0
    """... and within this orientation error [deg] (180: any)"""
    max_rad: float = 3.0
    """largest joint change [rad] the exact finish may make"""
    ik_iters: int = 50
    """damped-least-squares iterations of one attempt"""
    ik_step_rad: float = 0.3
    """largest joint change [rad] of one of those iterations"""
    ik_stall: int = 12
    """an attempt gives up once its errors have not dropped below 0.99 of their best for this many iterations
    (ik.stall_iters); 0: it runs all ik_iters"""
    every: int = 2
    """iterations between two attempts of one seed"""
    direct_first: bool = True
    """with `shortcut` on: before the first optimisation step, run the IK from the start itself and try the
    straight segment to its solution (a goal reachable in a straight line is taken without optimising)"""

    def __post_init__(self) -> None:
        problems = _problems(
            self,
            positive=("ik_step_rad",),
            non_negative=("max_rad",),
            at_least_one=("ik_iters", "every"),
            counts=("ik_stall",),
        )
        for name in ("radius_m", "angle_deg"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and v > 0):
                problems.append(f"{name} must be a number > 0 (inf: no limit), got {v!r}")
        _raise("finish.", problems)


@dataclass
class GuidanceConfig:
    """Goal guidance (`finish.GoalGuidance`, open loop): at the first restart, look for distinct IK solutions of
    the goal that pass the hard check; restarted seeds then take the joint-space distance to one of them as their
    target loss and (with the exact finish) finish by the straight segment to it (goals that need joints near
    their limits stall the pose loss)."""

    solutions: int = 4
    """at most this many goal configurations"""

    def __post_init__(self) -> None:
        _raise("guidance.", _problems(self, at_least_one=("solutions",)))


@dataclass
class EscapeConfig:
    """The RRT escape (`escape_part.RrtEscapePart`, open loop): when the latent search ends without the goal
    (every seed stalled, the step budget spent, or after_s passed), OMPL's RRTConnect searches joint space from
    the start to goal configurations on the same hard check, and the path is shortcut (the latent optimisation
    is local and stalls in bins, under shelves and behind walls)."""

    budget_s: float = 1.0
    """[s] longest search, goal IK included"""
    after_s: float = 0.25
    """[s] wall time of the latent search (from the start of the plan) after which the escape runs; if it finds
    no path, the latent search goes on to its own end. Earlier is faster but makes the escape the planner
    (docs/benchmark.md: at 0.05 s the workcell median drops from 0.12 to 0.10 s, but RRT paths become 57 % of the
    plans instead of 28 %, and every unsafe plan measured was an escape path); `bench table --amp-ls-set
    escape.after_s=0.05` measures it"""
    seen_share: float = 0.5
    """fraction of budget_s that a first search spends on the seen-space check (a state with part of the arm
    hidden from every camera behind an observed surface is refused; escape_part); if it finds no path, a search on
    the hard check alone gets budget_s again. 0: off; needs the cloud's camera origins"""
    attempts: int = 1
    """escapes per plan: after one that found no path, the latent search goes on and the next runs after_s later
    (or at once when the search ends), while the plan's time lasts (each attempt samples afresh). On the workcell
    training split 3 attempts solved one plan more in 96 but made two more unsafe plans (escape paths; see
    docs/benchmark.md), so one is the default"""
    seen_depth_m: float = 0.02
    """[m] how far behind an observed surface a point must lie to count as hidden (shadow_map.ShadowMap)"""
    fallback_depths_m: tuple[float, ...] = ()
    """[m] when the seen-space search at seen_depth_m finds no path, further seen-space searches (seen_share x
    budget_s each) at these depths (a path may then pass up to that far behind an observed surface), before the
    search on the hard check alone; () = none"""

    def __post_init__(self) -> None:
        _raise("escape.", _problems(self, positive=("budget_s",), non_negative=("after_s", "seen_depth_m")))
        depths = self.fallback_depths_m
        if not (isinstance(depths, tuple | list) and all(isinstance(d, int | float) and math.isfinite(d) and d > 0
                                                          for d in depths)):  # fmt: skip
            raise ValueError(f"escape.fallback_depths_m must be a list of positive depths [m], got {depths!r}")
        self.fallback_depths_m = tuple(float(d) for d in depths)
        if not (isinstance(self.attempts, int) and self.attempts >= 1):
            raise ValueError(f"escape.attempts must be an integer >= 1, got {self.attempts!r}")
        if not 0.0 <= self.seen_share <= 1.0:
            raise ValueError(f"escape.seen_share must be in [0, 1], got {self.seen_share}")


@dataclass
class PlanConfig:
    """Open-loop plans (`AmpLs.plan`) beyond the seed: their wall-time budget, the retry and the shortcutting."""

    timeout_s: float = 5.0
    """give a plan up after this wall time [s] (checked after each step; the RRT escape's budget is spent within
    it), as RRTConnect's 5 s; 0: the step budget alone (LSPP, whose plans take 5-8 s)"""
    geometric_retry: bool = True
    """learned backend: a plan that fails with the network is planned again with the geometric backend on the
    same cloud, within what is left of timeout_s (a scene unlike the network's training scenes can defeat it
    where the exact check does not)"""
    shortcut: bool = True
    """shorten a successful path by straight joint-space shortcuts that pass the same hard check as the accepted
    steps (planning/shortcut.py); with lazy checks, a seed reaching the goal first tries the straight segment from
    the start, before its own steps are checked"""

    def __post_init__(self) -> None:
        _raise("plan.", _problems(self, non_negative=("timeout_s",)))


@dataclass
class AmpLsConfig:
    """AMP-LS: the seed's algorithm (top level) and the parts beyond it (sub-configurations; None = off)."""

    lr: float = 0.06
    """latent step size (Adam learning rate) [latent units]; open-loop plans take search.plan_lr"""
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
    """"learned" (scene embedding + collision predictor), "geometric" (spheres vs cloud), "local" (the local
    collision predictor), "cylinders" (LSPP: the obstacle classifier on state-based cylinders) or "none\""""
    col_threshold: float = 0.2
    """gamma_col: a decoded state with p(collision) above this is not accepted"""
    interp_steps: int = 15
    """m: states checked on the linear interpolation of each accepted step (unless checks.check_step_rad > 0)"""
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
    speed_scale: float = 0.5
    """fraction of the joint velocity limits used by the time parameterisation"""
    search: SearchConfig = field(default_factory=SearchConfig)
    checks: CheckConfig = field(default_factory=CheckConfig)
    plan: PlanConfig = field(default_factory=PlanConfig)
    finish: FinishConfig | None = field(default_factory=FinishConfig)
    guidance: GuidanceConfig | None = field(default_factory=GuidanceConfig)
    escape: EscapeConfig | None = field(default_factory=EscapeConfig)

    def __post_init__(self) -> None:
        problems = []
        if self.optimizer not in ("adam", "sgd"):
            problems.append(f"optimizer must be 'adam' or 'sgd', got {self.optimizer!r}")
        if self.collision_backend not in BACKENDS:
            problems.append(f"collision_backend must be one of {BACKENDS}, got {self.collision_backend!r}")
        problems += _problems(
            self,
            positive=("lr", "pos_tol", "ori_tol_deg", "speed_scale", "lambda_min", "lambda_max"),
            at_least_one=("max_steps", "interp_steps"),
        )
        if not (isinstance(self.col_threshold, int | float) and 0.0 < self.col_threshold < 1.0):
            problems.append(f"col_threshold must be in (0, 1), got {self.col_threshold!r}")
        if not (isinstance(self.geco_alpha_ma, int | float) and 0.0 <= self.geco_alpha_ma < 1.0):
            problems.append(f"geco_alpha_ma must be in [0, 1), got {self.geco_alpha_ma!r}")
        if isinstance(self.speed_scale, int | float) and self.speed_scale > 1.0:
            problems.append(f"speed_scale must be <= 1, got {self.speed_scale}")
        parts = {
            "search": SearchConfig,
            "checks": CheckConfig,
            "plan": PlanConfig,
            "finish": FinishConfig,
            "guidance": GuidanceConfig,
            "escape": EscapeConfig,
        }
        for name, cls in parts.items():
            v = getattr(self, name)
            optional = name in ("finish", "guidance", "escape")
            if not (isinstance(v, cls) or (optional and v is None)):
                problems.append(f"{name} must be a {cls.__name__}{' or None' if optional else ''}, got {v!r}")
        _raise("", problems)

    @property
    def ori_tol(self) -> float:
        """[rad] orientation tolerance"""
        return math.radians(self.ori_tol_deg)

    def to_dict(self) -> dict:
        """The configuration as nested plain values (a part that is off: None)."""
        return asdict(self)


PARTS = {
    "search": SearchConfig,
    "checks": CheckConfig,
    "plan": PlanConfig,
    "finish": FinishConfig,
    "guidance": GuidanceConfig,
    "escape": EscapeConfig,
}
"""The sub-configurations by field name."""


def with_overrides(config: AmpLsConfig, overrides: dict) -> AmpLsConfig:
    """config with `overrides` applied: {"lr": 0.03, "search.n_seeds": 16, "finish": None, "escape.budget_s": 2}.

    A dotted key sets a part's field (a part that is off is switched on with its defaults first); a part's name
    set to None switches it off. ValueError names an unknown field or a value the configuration refuses.
    """
    top: dict = {}
    nested: dict[str, dict] = {}
    for key, value in overrides.items():
        part, _, name = key.partition(".")
        if not name:
            if key not in {f.name for f in fields(AmpLsConfig)}:
                raise ValueError(f"unknown AMP-LS field {key!r}")
            top[key] = value
            continue
        if part not in PARTS or name not in {f.name for f in fields(PARTS[part])}:
            raise ValueError(f"unknown AMP-LS field {key!r}")
        nested.setdefault(part, {})[name] = value
    for part, values in nested.items():
        if part in top and top[part] is None:
            raise ValueError(f"AMP-LS overrides switch {part} off and set {part}.{next(iter(values))}: choose one")
        current = top.get(part, getattr(config, part))
        top[part] = replace(current if current is not None else PARTS[part](), **values)
    return replace(config, **top)
