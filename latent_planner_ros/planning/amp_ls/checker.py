"""The segment checker of AMP-LS: the hard check of interpolated steps, the start's escape, lazy verification.

Seed chapter 7, Algorithm 1 checks the linear interpolation from the last accepted state to each new one
explicitly; beyond the seed, the interpolation is densified per joint-space step (checks.check_step_rad), the
arm's self- and table collisions are checked with it (checks.self_check), a start that itself fails the check is
left through states near it (checks.escape_rad), and open-loop plans check a seed's accepted steps lazily, in one
batch once it reaches the goal (`verify`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import torch

from latent_planner_ros.planning.amp_ls.config import AmpLsConfig
from latent_planner_ros.planning.amp_ls.search import LatentSearch
from latent_planner_ros.planning.collision_backend import CollisionBackend
from latent_planner_ros.planning.plan_clock import PlanClock
from latent_planner_ros.planning.shadow_map import HiddenArm
from latent_planner_ros.planning.time_parameterisation import interpolate
from latent_planner_ros.robot.collision import CollisionChecker


class SegmentChecker:
    """Hard checks of joint-space segments against the backend's current scene and the robot itself.

    Args:
        backend: the collision backend (its `check` is the scene's hard decision).
        config: the planner's configuration (use_collision, interp_steps, checks).
        clock: where the time of the checks is counted (section "check", count "checked_states").
        robot: the exact self- and table-collision checker (checks.self_check).

    `escape_from` (7,) [rad] or None: while set, states within checks.escape_rad of it are not refused.
    `hidden_arm` (shadow_map.HiddenArm) or None: while set, a state that puts part of the arm where no camera has
    seen is refused too (`seen_only`).

    Within `cached()` (one open-loop plan, one scene) each state's answer is kept and a state checked again is not
    recomputed: the exact finish, the lazy verification and the shortcutting check the same interpolated states
    again (about two in five of a tabletop plan's states).
    """

    def __init__(self, backend: CollisionBackend, config: AmpLsConfig, clock: PlanClock, robot: CollisionChecker):
        self.backend = backend
        self.config = config
        self.clock = clock
        self.robot = robot
        self.escape_from: np.ndarray | None = None
        self.hidden_arm: HiddenArm | None = None
        self._cache: dict[bytes, bool] | None = None  # state bytes -> hit, within `cached()`

    @contextmanager
    def cached(self) -> Iterator[None]:
        """Keep each checked state's answer within the block. The backend's scene must not change inside it."""
        self._cache = {}
        try:
            yield
        finally:
            self._cache = None

    @contextmanager
    def seen_only(self, arm: HiddenArm) -> Iterator[None]:
        """Within the block a state also fails the check when a sphere centre of the arm is hidden from every
        camera (`arm.hidden`): the stricter check of the RRT escape's first attempt."""
        self.hidden_arm = arm
        try:
            yield
        finally:
            self.hidden_arm = None

    def n_checks(self, q_from: np.ndarray, q_to: np.ndarray) -> int:
        """m, the states checked on a step q_from (7,) -> q_to (7,) [rad]: interp_steps, or (checks.check_step_rad
        > 0) one per check_step_rad [rad]."""
        step = self.config.checks.check_step_rad
        if step <= 0:
            return self.config.interp_steps
        return max(1, int(np.ceil(np.abs(q_to - q_from).max() / step)))

    def densify(self, q_from: np.ndarray, q_to: np.ndarray) -> np.ndarray:
        """The states (m, 7) [rad] hard-checked on the straight segment q_from (7,) -> q_to (7,) [rad], q_from
        excluded: the interpolation of an accepted step."""
        return interpolate(q_from, q_to, self.n_checks(q_from, q_to))

    def check_segments(self, segs: list[np.ndarray]) -> list[np.ndarray]:
        """Hard checks of interpolated segments [(m, 7)] [rad] in one batch: a (m,) bool hit mask per segment."""
        if not segs:
            return []
        with self.clock.section("check"):
            return self._check_states(segs)

    def _check_states(self, segs: list[np.ndarray]) -> list[np.ndarray]:
        cfg = self.config
        states = np.concatenate(segs)
        ends = np.cumsum([len(seg) for seg in segs])[:-1]
        if self._cache is None:
            self.clock.counts["checked_states"] += len(states)
            hits = self.backend.check(states) if cfg.use_collision else np.zeros(len(states), dtype=bool)
            if cfg.checks.self_check:  # only the states before each segment's first hit matter
                todo = np.concatenate([np.cumsum(h) == 0 for h in np.split(hits, ends)])
                hits[todo] |= ~self.robot.feasible(states[todo])
        else:
            hits = self._cached_hits(states)
        if self.hidden_arm is not None and not hits.all():  # not cached: the plain answers stay valid
            hits[~hits] = self.hidden_arm.hidden(states[~hits])
        if self.escape_from is not None:
            hits &= np.abs(states - self.escape_from).max(axis=1) > cfg.checks.escape_rad
        return np.split(hits, ends)

    def _cached_hits(self, states: np.ndarray) -> np.ndarray:
        """Hits (M,) of states (M, 7) [rad]: the kept answers, and the others checked (scene, then self and table
        for the states the scene passes) and kept."""
        cache = self._cache
        assert cache is not None
        keys = [row.tobytes() for row in np.ascontiguousarray(states, dtype=np.float64)]
        hits = np.zeros(len(states), dtype=bool)
        new: dict[bytes, int] = {}  # key -> first row of a state not kept yet (a batch may repeat one)
        for i, key in enumerate(keys):
            if key in cache:
                hits[i] = cache[key]
            else:
                new.setdefault(key, i)
        if new:
            rows = np.fromiter(new.values(), dtype=np.int64, count=len(new))
            todo = states[rows]
            self.clock.counts["checked_states"] += len(todo)
            fresh = self.backend.check(todo) if self.config.use_collision else np.zeros(len(todo), dtype=bool)
            if self.config.checks.self_check and not fresh.all():
                fresh[~fresh] = ~self.robot.feasible(todo[~fresh])
            cache.update(zip(new, fresh.tolist(), strict=True))
            hits = np.fromiter((cache[key] for key in keys), dtype=bool, count=len(keys))
        return hits

    def state_free(self, q: np.ndarray) -> bool:
        """True if the state q (7,) [rad] passes the hard check."""
        return not self.check_segments([np.asarray(q, dtype=float)[None]])[0][0]

    def free(self, seg: np.ndarray, stride: int = 4) -> bool:
        """True if every state of the segment (m, 7) [rad] passes the hard check: every stride-th state first, the
        rest only if those pass (a colliding segment is usually refused at a quarter of the cost)."""
        coarse = np.zeros(len(seg), dtype=bool)
        coarse[stride - 1 :: stride] = True
        coarse[-1] = True
        if self.check_segments([seg[coarse]])[0].any():
            return False
        return not (len(seg) > coarse.sum() and self.check_segments([seg[~coarse]])[0].any())

    def segment_free(self, q_from: np.ndarray, q_to: np.ndarray) -> bool:
        """True if the straight segment q_from (7,) -> q_to (7,) [rad] passes the hard check."""
        return self.free(self.densify(np.asarray(q_from, dtype=float), np.asarray(q_to, dtype=float)))

    def verify(self, s: LatentSearch, seeds: list[int]) -> list[int]:
        """Lazy verification: hard-check the unchecked steps of `seeds` in one batch. A free chain joins the path;
        a colliding one joins it up to the step that collides, and the seed back-traces to the state before that
        step (its target weights scaled by i/m, as in Algorithm 1). Returns the seeds that back-traced."""
        chains = {}
        for b in seeds:
            vertices = [s.q_ok[b]] + [q for q, _ in s.pending[b]]
            chains[b] = [self.densify(a, c) for a, c in zip(vertices[:-1], vertices[1:], strict=True)]
        hits = iter(self.check_segments([seg for b in seeds for seg in chains[b]]))
        backtraced = []
        for b in seeds:
            chain = chains[b]
            chain_hits = [next(hits) for _ in chain]
            bad = [k for k, h in enumerate(chain_hits) if h.any()]
            j = bad[0] if bad else len(chain)
            s.paths[b].extend(chain[:j])
            if j > 0:
                s.q_ok[b], s.z_ok[b] = s.pending[b][j - 1][0], s.pending[b][j - 1][1]
            s.pending[b] = []
            if not bad:
                continue
            i = int(np.argmax(chain_hits[j])) + 1
            s.target.scale(np.where(np.arange(len(s.q_prev)) == b, i / len(chain[j]), 1.0))
            s.q_prev[b] = s.q_ok[b]
            with torch.no_grad():
                s.z_prev[b] = s.z_ok[b]
                s.z[b] = s.z_ok[b]
            s.backtraces += 1
            backtraced.append(b)
        return backtraced

    def verify_all(self, s: LatentSearch) -> None:
        """Lazy verification of every seed with unchecked steps."""
        self.verify(s, [b for b in range(len(s.paths)) if s.pending[b]])
