"""Greedy shortcutting of a collision-checked joint path (beyond the seed).

AMP-LS's path is the chain of states the latent optimisation accepted: it wanders (the seed reports 5.25 times
the start-goal distance). Like OMPL's path simplification, this replaces runs of the chain by straight
joint-space segments that pass the same hard check as every accepted step.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def candidates(i: int, last: int) -> list[int]:
    """Vertices tried from vertex i: last, then halving the remaining span down to i + 2 (i + 1 is already joined
    by the path), furthest first."""
    out, span = [], last - i
    while span >= 2:
        out.append(i + span)
        span //= 2
    return out


def shortcut(
    vertices: np.ndarray,
    densify: Callable[[np.ndarray, np.ndarray], np.ndarray],
    check: Callable[[list[np.ndarray]], list[np.ndarray]],
    max_rounds: int = 16,
) -> list[int]:
    """Indices of the kept vertices of a free chain vertices (N, 7) [rad] (consecutive vertices joined by free
    segments), from 0 to N - 1.

    From the current vertex i each round densifies and checks the straight segments to the `candidates`, furthest
    first, and jumps to the first one whose segment is free (else to i + 1). After `max_rounds` rounds the rest
    of the chain is kept as it is.

    Args:
        densify: (q_from (7,), q_to (7,)) -> the states (m, 7) to check on the segment, q_from excluded.
        check: segments [(m, 7)] -> a (m,) bool hit mask per segment.
    """
    n = len(vertices)
    kept, i, rounds = [0], 0, 0
    while i < n - 1:
        if rounds >= max_rounds:
            kept.extend(range(i + 1, n))
            break
        free = next((j for j in candidates(i, n - 1) if not check([densify(vertices[i], vertices[j])])[0].any()), None)
        i = i + 1 if free is None else free
        kept.append(i)
        rounds += 1
    return kept
