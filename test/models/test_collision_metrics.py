"""Classifier scores of the collision benchmark: the best recall at a precision floor, the ROC curve, recall per bin."""

import numpy as np

from latent_planner_ros.models.collision_metrics import (
    auroc,
    precision_recall,
    recall_at_precision,
    recall_by_bins,
    roc_curve,
)


def test_recall_at_precision_is_the_best_over_every_threshold(rng):
    labels = rng.random(400) < 0.5
    p = np.clip(0.5 * labels + rng.normal(0.25, 0.25, 400), 0, 1).round(2)  # ties included
    recall, threshold = recall_at_precision(p, labels, 0.88)
    brute = [precision_recall(p, labels, t) for t in np.unique(p)]
    best = max(r for prec, r in brute if prec >= 0.88)
    assert recall == best
    prec, rec = precision_recall(p, labels, threshold)
    assert prec >= 0.88 and rec == recall


def test_recall_at_precision_without_an_answer_is_nan():
    labels = np.array([True, False, True, False])
    assert np.isnan(recall_at_precision(np.array([0.1, 0.9, 0.2, 0.8]), labels, 0.9)[0])
    assert np.isnan(recall_at_precision(np.ones(3), np.ones(3, dtype=bool), 0.5)[0])
    assert recall_at_precision(np.array([0.9, 0.1, 0.8, 0.2]), labels, 0.9) == (1.0, 0.8)


def test_roc_curve_runs_from_origin_to_one_and_its_area_is_the_auroc(rng):
    labels = rng.random(300) < 0.4
    p = np.clip(0.4 * labels + rng.normal(0.3, 0.2, 300), 0, 1).round(2)
    fpr, tpr = roc_curve(p, labels)
    assert (fpr[0], tpr[0], fpr[-1], tpr[-1]) == (0.0, 0.0, 1.0, 1.0)
    assert np.all(np.diff(fpr) >= 0) and np.all(np.diff(tpr) >= 0)
    assert abs(np.trapezoid(tpr, fpr) - auroc(p, labels)) < 1e-9


def test_recall_by_bins_counts_positives_per_bin_and_their_mix_is_the_recall(rng):
    labels = rng.random(500) < 0.5
    p, x = rng.random(500), rng.uniform(0, 0.1, 500)
    edges = [0.0, 0.01, 0.05, np.inf]
    out = recall_by_bins(p, labels, x, edges, 0.3)
    bins = zip(edges[:-1], edges[1:], strict=True)
    assert out["count"] == [int((labels & (x >= lo) & (x < hi)).sum()) for lo, hi in bins]
    assert sum(out["count"]) == labels.sum()
    mixed = np.dot(out["recall"], out["count"]) / sum(out["count"])
    assert abs(mixed - precision_recall(p, labels, 0.3)[1]) < 1e-12
    small = recall_by_bins(np.array([0.9, 0.1]), np.array([True, True]), np.array([0.0, 0.0]), [0, 1, 2], 0.5)
    assert small["recall"][0] == 0.5 and np.isnan(small["recall"][1]) and small["count"] == [2, 0]
