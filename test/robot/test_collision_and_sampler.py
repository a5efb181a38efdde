"""Self/table collision checks and the feasible-state sampler."""

import numpy as np

from latent_planner_ros.robot.collision import CollisionChecker
from latent_planner_ros.robot.limits import Q_READY, within_limits
from latent_planner_ros.robot.panda import LINK_FRAMES, load_panda
from latent_planner_ros.robot.sampler import FeasibleSampler


def test_ready_pose_is_free():
    assert CollisionChecker().collisions(Q_READY) == (False, False)


def test_srdf_pairs_are_excluded():
    checker = CollisionChecker()
    names = {tuple(sorted((a.rsplit("_", 1)[0], b.rsplit("_", 1)[0]))) for a, b in checker.pair_names}
    assert ("panda_link0", "panda_link1") not in names  # adjacent, disabled by the SRDF
    assert ("panda_hand", "panda_link7") not in names
    assert ("panda_link1", "panda_link5") in names or ("panda_link0", "panda_link5") in names


def test_hand_pushed_into_the_table_is_a_table_collision():
    q = Q_READY.copy()
    q[1], q[3] = 1.7, -0.3  # lean forward, stretch: the hand goes below z = 0
    tcp_z = load_panda().fk(q).translation[2]
    assert tcp_z < -0.05
    self_hit, table_hit = CollisionChecker().collisions(q)
    assert table_hit
    assert CollisionChecker(table=False).collisions(q)[1] is False


def test_folded_arm_is_a_self_collision():
    q = np.array([0.0, 0.0, 0.0, -3.0, 0.0, 0.0, 0.0])  # elbow fully folded, hand on the shoulder
    assert CollisionChecker(table=False).collisions(q)[0]


def test_sampler_returns_feasible_states_within_limits(rng):
    sampler = FeasibleSampler(rng)
    q = sampler.sample(500)
    assert q.shape == (500, 7)
    assert within_limits(q).all()
    checker = CollisionChecker()
    assert not any(checker.in_collision(qi) for qi in q[:200])
    # every link frame above the table for a sample of states
    panda = load_panda()
    for qi in q[:20]:
        for f in LINK_FRAMES[1:]:
            assert panda.fk(qi, f).translation[2] > -0.05


def test_sampler_is_reproducible():
    a = FeasibleSampler(np.random.default_rng(3)).sample(50)
    b = FeasibleSampler(np.random.default_rng(3)).sample(50)
    np.testing.assert_array_equal(a, b)


def test_convex_hulls_are_conservative_and_close_to_the_meshes(rng):
    from latent_planner_ros.robot.limits import Q_MAX, Q_MIN

    q = rng.uniform(Q_MIN, Q_MAX, (400, 7))
    meshes, hulls = CollisionChecker().feasible(q), CollisionChecker(convex=True).feasible(q)
    assert not np.any(hulls & ~meshes)  # free for the hulls => free for the meshes they enclose
    assert 0 < meshes.sum() and (meshes & ~hulls).sum() <= 0.05 * meshes.sum()
    assert CollisionChecker(convex=True).collisions(Q_READY) == (False, False)
    assert CollisionChecker(table=False, convex=True).collisions(np.array([0.0, 0.0, 0.0, -3.0, 0.0, 0.0, 0.0]))[0]


def test_batch_broad_phase_agrees_with_every_pair_checked(rng):
    """`feasible` (one broad-phase call per batch) and `in_collision` (broad phase, one configuration) decide
    exactly as the narrow phase on every active pair (`collisions`)."""
    import pytest

    from latent_planner_ros.robot.limits import Q_MAX, Q_MIN

    q = rng.uniform(Q_MIN, Q_MAX, (600, 7))
    q[:100, 3] = rng.uniform(-3.07, -2.6, 100)  # folded elbows: many self-collisions
    for table, convex in ((True, True), (False, True), (True, False)):
        checker = CollisionChecker(table=table, convex=convex)
        batch = checker.feasible(q)
        one_by_one = np.array([not checker.in_collision(qi) for qi in q])
        every_pair = np.array([not any(checker.collisions(qi)) for qi in q])  # narrow phase on all pairs
        np.testing.assert_array_equal(batch, every_pair)
        np.testing.assert_array_equal(one_by_one, every_pair)
        assert 0 < (~batch).sum() < len(q)  # both outcomes occur
    assert CollisionChecker().feasible(np.zeros((0, 7))).shape == (0,)
    with pytest.raises(ValueError, match="7 joints"):
        CollisionChecker().feasible(np.zeros((3, 6)))


def test_batch_checks_leave_torch_threads_alone():
    """pinocchio's batch call sets the process's OpenMP thread count (shared with torch) to 1; it is restored."""
    import torch

    before = torch.get_num_threads()
    try:
        torch.set_num_threads(2)
        CollisionChecker(convex=True).feasible(np.zeros((4, 7)))
        assert torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(before)
