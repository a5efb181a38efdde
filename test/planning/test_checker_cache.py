"""Within one plan the segment checker keeps each state's answer: the same hits as checking afresh, and a state
asked again is not given to the backend again."""

import numpy as np

from latent_planner_ros.planning.amp_ls import AmpLs, AmpLsConfig
from latent_planner_ros.planning.collision_backend import BackendDefaults
from latent_planner_ros.planning.goal import Goal
from latent_planner_ros.robot.limits import Q_READY
from latent_planner_ros.robot.panda import load_panda


class CountingBox(BackendDefaults):
    """Hits where joints 0 and 1 both lie in (0.3, 0.7); counts every state it is asked about."""

    name = "geometric"

    def __init__(self):
        self.asked = 0

    def set_scene(self, scene, origin=None) -> None:
        pass

    def p_collision(self, q, z, frames=None):
        return q[:, 0] * 0.0

    def check(self, q: np.ndarray) -> np.ndarray:
        q = np.atleast_2d(q)
        self.asked += len(q)
        return np.all((q[:, :2] > 0.3) & (q[:, :2] < 0.7), axis=1)


def _planner(vae) -> tuple[AmpLs, CountingBox]:
    backend = CountingBox()
    return AmpLs(vae, backend, AmpLsConfig(collision_backend="geometric")), backend


def test_cached_answers_equal_fresh_ones_and_repeats_are_not_recomputed(shipped_vae):
    planner, backend = _planner(shipped_vae)
    rng = np.random.default_rng(0)
    segs = [Q_READY + rng.uniform(-1.0, 1.0, (n, 7)) for n in (5, 1, 30, 12)]
    segs[0][:, :2] = 0.5  # every state of the first segment in the box
    segs.append(segs[2].copy())  # a segment asked twice in one batch
    fresh = planner.segments.check_segments(segs)
    asked_fresh = backend.asked
    backend.asked = 0
    with planner.segments.cached():
        first = planner.segments.check_segments(segs)
        again = planner.segments.check_segments(segs[2:4])
    distinct = len(np.unique(np.concatenate(segs), axis=0))
    assert backend.asked == distinct < asked_fresh  # each distinct state once, none of the second call's
    for a, b in zip(fresh, first, strict=True):
        # the fresh check leaves self-collisions after a segment's first hit unchecked: the first hits agree
        assert a.any() == b.any() and (not a.any() or np.argmax(a) == np.argmax(b))
    for a, b in zip(first[2:4], again, strict=True):
        np.testing.assert_array_equal(a, b)
    assert planner.segments._cache is None  # off after the block
    planner.segments.check_segments(segs[1:2])
    assert backend.asked == distinct + 1


def test_a_plan_checks_each_state_once(shipped_vae):
    planner, backend = _planner(shipped_vae)
    asked = []
    real_check = backend.check

    def recording(q):
        asked.extend(map(bytes, np.atleast_2d(np.ascontiguousarray(q, dtype=np.float64))))
        return real_check(q)

    backend.check = recording
    start = Q_READY + np.array([0.0, 1.285, 0.0, 0.0, 0.0, 0.0, 0.0])  # (q0, q1) = (0, 0.5), left of the box
    pose = load_panda().fk(start + np.array([0.9, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]))  # right of it: straight is blocked
    result = planner.plan(start, Goal(pose.translation, pose.rotation), None)
    assert result.success
    assert len(asked) == len(set(asked)) > 0
