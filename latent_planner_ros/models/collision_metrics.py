"""Scores of a binary collision classifier: AUROC, precision/recall at a threshold, calibration bins."""

from __future__ import annotations

import numpy as np
from scipy.stats import rankdata


def _cuts(scores: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every decision "score >= t" over the distinct scores t, highest first: t (K,), true and false positives (K,)."""
    scores = np.asarray(scores, dtype=float).ravel()
    labels = np.asarray(labels, dtype=bool).ravel()
    order = np.argsort(-scores, kind="stable")
    s, y = scores[order], labels[order]
    last = np.r_[np.flatnonzero(np.diff(s)), len(s) - 1]  # end of each run of equal scores
    return s[last], np.cumsum(y)[last], np.cumsum(~y)[last]


def auroc(scores: np.ndarray, labels: np.ndarray) -> float:
    """Area under the ROC curve (Mann-Whitney U with tie correction); nan if one class is absent."""
    scores = np.asarray(scores, dtype=float).ravel()
    labels = np.asarray(labels, dtype=bool).ravel()
    n_pos, n_neg = int(labels.sum()), int((~labels).sum())
    if n_pos == 0 or n_neg == 0:
        return float("nan")
    ranks = rankdata(scores)
    return float((ranks[labels].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg))


def precision_recall(p: np.ndarray, labels: np.ndarray, threshold: float) -> tuple[float, float]:
    """(precision, recall) of the decision p >= threshold; nan where undefined."""
    pred = np.asarray(p).ravel() >= threshold
    labels = np.asarray(labels, dtype=bool).ravel()
    tp = float((pred & labels).sum())
    precision = tp / pred.sum() if pred.any() else float("nan")
    recall = tp / labels.sum() if labels.any() else float("nan")
    return precision, recall


def recall_at_precision(p: np.ndarray, labels: np.ndarray, min_precision: float) -> tuple[float, float]:
    """(recall, threshold): the largest recall of a decision p >= threshold whose precision is at least
    min_precision, over every threshold (nan, nan if none reaches it or a class is absent)."""
    thresholds, tp, fp = _cuts(p, labels)
    if not len(tp) or not tp[-1] or not fp[-1]:
        return float("nan"), float("nan")
    ok = np.flatnonzero(tp >= min_precision * (tp + fp))
    if not len(ok):
        return float("nan"), float("nan")
    best = ok[np.argmax(tp[ok])]
    return float(tp[best] / tp[-1]), float(thresholds[best])


def calibration_bins(p: np.ndarray, labels: np.ndarray, n_bins: int = 10) -> dict:
    """Reliability diagram data: per equal-width probability bin the mean prediction, positive rate, count;
    plus the expected calibration error (count-weighted mean |mean prediction - positive rate|)."""
    p = np.asarray(p, dtype=float).ravel()
    labels = np.asarray(labels, dtype=float).ravel()
    idx = np.minimum((p * n_bins).astype(int), n_bins - 1)
    count = np.bincount(idx, minlength=n_bins)
    safe = np.maximum(count, 1)
    mean_p = np.bincount(idx, p, minlength=n_bins) / safe
    rate = np.bincount(idx, labels, minlength=n_bins) / safe
    ece = float((count * np.abs(mean_p - rate)).sum() / max(count.sum(), 1))
    return {"mean_p": mean_p.tolist(), "positive_rate": rate.tolist(), "count": count.tolist(), "ece": ece}


def roc_curve(scores: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """False and true positive rates (K,) over all thresholds, from (0, 0) to (1, 1)."""
    _, tp, fp = _cuts(scores, labels)
    return np.r_[0.0, fp / max(fp[-1], 1)], np.r_[0.0, tp / max(tp[-1], 1)]


def recall_by_bins(p: np.ndarray, labels: np.ndarray, x: np.ndarray, edges, threshold: float) -> dict:
    """Recall of the decision p >= threshold among the positives, per bin edges[k] <= x < edges[k + 1] of an
    auxiliary quantity x (same shape as p): {"recall": [K] (nan in empty bins), "count": [K] positives}."""
    p, x = np.asarray(p, dtype=float).ravel(), np.asarray(x, dtype=float).ravel()
    pos = np.asarray(labels, dtype=bool).ravel()
    recall, count = [], []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        m = pos & (x >= lo) & (x < hi)
        count.append(int(m.sum()))
        recall.append(float((p[m] >= threshold).mean()) if m.any() else float("nan"))
    return {"recall": recall, "count": count}
