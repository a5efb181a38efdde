"""One closed-loop reaching trial: metrics from its logged time series, the summary, the plot. No ROS.

A :class:`TrialLog` holds what a monitor received during a trial, as arrays over time [s] of simulated time
from the trial's start. :func:`trial_metrics` applies the success rule of the seed's conveyor experiment
(chapter 7, V-D): the end effector gets within ``pos_tol_m`` and ``ori_tol_deg`` of the (moving) target and
then stays within for ``hold_s``, with no contact between the arm and the scene at any time.

    log = monitor.end_trial()
    metrics = trial_metrics(log)            # a flat dict of plain Python values (JSON-ready)
    print(format_summary(metrics))
    plot_tracking(tracking(log)).savefig("tracking.png")
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from latent_planner_ros.evaluation.stats import percentile
from latent_planner_ros.robot.rotations import quat_to_matrix


@dataclass(frozen=True)
class SuccessRule:
    """When a trial counts as reached, tracked and successful.

    Attributes:
        pos_tol_m: [m] end-effector to target distance that counts as "at the target".
        ori_tol_deg: [deg] end-effector to target rotation angle that counts as "at the target".
        hold_s: [s] how long the end effector must stay at the moving target after reaching it.
    """

    pos_tol_m: float = 0.03
    ori_tol_deg: float = 20.0
    hold_s: float = 2.0


def _array(shape_tail: tuple[int, ...] = (), dtype=float) -> np.ndarray:
    return np.zeros((0, *shape_tail), dtype=dtype)


@dataclass(frozen=True)
class TrialLog:
    """Time series of one trial. Times are [s] of simulated time since the trial started (may be < 0 for
    samples received just before); each series is sorted by time.

    Attributes:
        duration_s: [s] length of the trial.
        joint_t, q: (N,) times and (N, 7) [rad] measured joint positions (``joint_states``).
        target_t, target_position, target_quaternion: (M,), (M, 3) [m], (M, 4) xyzw target poses (``target_pose``).
        contact_t, contact: (K,) times and (K,) bool, the arm touched the scene (``sim/in_collision``).
        distance_t, distance: (L,) times and (L,) [m] arm-to-objects clearance (``sim/min_distance``).
        status_t, status_state, status_message, status_source, tick_ms: (S,) times, planner states, status
            messages, command sources ("local", "servo", "plan", ...; "" where the status had none) and tick
            compute times [ms] (NaN where the status had none) from ``planner/status``.
        status_servo_note: (S,) why the IK servo declined that tick (status ``servo_note``; "" where it did not).
        command_t: (C,) stamps of the planner's ``joint_command`` messages.
        command_period_s: [s] the planner's control period.
        scenario_start_s: trial time at which the scenario was (re)started (scenario time = t - this).
    """

    duration_s: float
    joint_t: np.ndarray = field(default_factory=_array)
    q: np.ndarray = field(default_factory=lambda: _array((7,)))
    target_t: np.ndarray = field(default_factory=_array)
    target_position: np.ndarray = field(default_factory=lambda: _array((3,)))
    target_quaternion: np.ndarray = field(default_factory=lambda: _array((4,)))
    contact_t: np.ndarray = field(default_factory=_array)
    contact: np.ndarray = field(default_factory=lambda: _array(dtype=bool))
    distance_t: np.ndarray = field(default_factory=_array)
    distance: np.ndarray = field(default_factory=_array)
    status_t: np.ndarray = field(default_factory=_array)
    status_state: tuple[str, ...] = ()
    status_message: tuple[str, ...] = ()
    status_source: tuple[str, ...] = ()
    status_servo_note: tuple[str, ...] = ()
    tick_ms: np.ndarray = field(default_factory=_array)
    command_t: np.ndarray = field(default_factory=_array)
    command_period_s: float = 0.1
    scenario_start_s: float = 0.0


@dataclass(frozen=True)
class Tracking:
    """End effector against target at every joint-state sample from the first target on.

    Attributes:
        t: (N,) [s]; ee_position, target_position: (N, 3) [m]; pos_err_m: (N,) [m]; ori_err_deg: (N,) [deg];
        within: (N,) bool, both errors within the rule's tolerances; q: (N, 7) [rad].
    """

    t: np.ndarray
    q: np.ndarray
    ee_position: np.ndarray
    target_position: np.ndarray
    pos_err_m: np.ndarray
    ori_err_deg: np.ndarray
    within: np.ndarray


def target_at(
    t: np.ndarray, target_t: np.ndarray, position: np.ndarray, quaternion: np.ndarray, jump_m: float = 0.05
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The target pose at times t (N,), from samples at target_t (M,).

    Positions are interpolated linearly between consecutive samples (the target moves smoothly between them),
    except across a jump larger than `jump_m` [m] (a new target, or an object wrapping round the belt), where
    the earlier sample holds; orientations hold the latest sample.

    Returns:
        position (N, 3) [m], rotation (N, 3, 3), known (N,) bool (False before the first sample; rows undefined).
    """
    t = np.asarray(t, dtype=float)
    n = len(t)
    if len(target_t) == 0:
        return np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.zeros(n, dtype=bool)
    i = np.searchsorted(target_t, t, side="right") - 1
    known = i >= 0
    i = np.clip(i, 0, len(target_t) - 1)
    j = np.minimum(i + 1, len(target_t) - 1)
    span = target_t[j] - target_t[i]
    smooth = (j > i) & (np.linalg.norm(position[j] - position[i], axis=1) <= jump_m) & (span > 0)
    w = np.where(smooth, (t - target_t[i]) / np.where(span > 0, span, 1.0), 0.0)
    w = np.clip(w, 0.0, 1.0)[:, None]
    pos = (1 - w) * position[i] + w * position[j]
    rot = quat_to_matrix(quaternion)[i]
    return pos, rot, known


def tracking(log: TrialLog, rule: SuccessRule | None = None) -> Tracking:
    """End-effector (pinocchio FK of ``panda_hand_tcp``) against target at every joint-state sample."""
    from latent_planner_ros.robot.panda import load_panda

    rule = rule or SuccessRule()
    tpos, trot, known = target_at(log.joint_t, log.target_t, log.target_position, log.target_quaternion)
    t, q = log.joint_t[known], log.q[known]
    if len(q):
        ee_pos, ee_rot = load_panda().fk_batch(q)
    else:
        ee_pos, ee_rot = np.zeros((0, 3)), np.zeros((0, 3, 3))
    tpos, trot = tpos[known], trot[known]
    pos_err = np.linalg.norm(ee_pos - tpos, axis=1)
    cos = (np.einsum("nij,nij->n", ee_rot, trot) - 1.0) / 2.0  # trace(R_ee^T R_target)
    ori_err = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    within = (pos_err <= rule.pos_tol_m) & (ori_err <= rule.ori_tol_deg)
    return Tracking(t, q, ee_pos, tpos, pos_err, ori_err, within)


def within_runs(t: np.ndarray, within: np.ndarray, end_s: float) -> list[tuple[float, float]]:
    """Maximal time intervals [start, end) [s] during which every sample is within.

    Sample i stands for [t_i, t_{i+1}); the last one for one median sample period, at most until `end_s`.
    """
    if len(t) == 0:
        return []
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    ends = np.append(t[1:], min(t[-1] + dt, max(end_s, t[-1])))
    runs = []
    start = None
    for k, inside in enumerate(within):
        if inside and start is None:
            start = t[k]
        if start is not None and (not inside or k == len(t) - 1):
            runs.append((float(start), float(ends[k] if inside else t[k])))
            start = None
    return runs


def contact_events(contact: np.ndarray) -> int:
    """Number of contacts that began (rising edges; a series starting in contact counts one)."""
    c = np.asarray(contact, dtype=bool)
    return int(np.sum(c[1:] & ~c[:-1]) + (1 if len(c) and c[0] else 0))


def tick_samples(tick_ms: np.ndarray) -> np.ndarray:
    """Tick compute times [ms] from status samples: NaNs dropped, a value repeated by consecutive statuses
    (the same tick reported twice) kept once."""
    v = np.asarray(tick_ms, dtype=float)
    v = v[np.isfinite(v)]
    if len(v) < 2:
        return v
    return v[np.r_[True, v[1:] != v[:-1]]]


def missed_ticks(command_t: np.ndarray, period_s: float, duration_s: float) -> int:
    """Control periods of the trial [0, duration_s] without a joint_command (stamps command_t [s]).

    Periods are counted on the grid of the commands received: the gaps between them (a late tick is not
    missed), plus whole periods before the first and after the last beyond half a period of timer jitter (a
    window edge falls anywhere between two ticks).
    """
    c = _in_window(command_t, duration_s)
    if len(c) == 0:
        return int(np.floor(duration_s / period_s + 1e-9))
    expected = int(np.floor((c[-1] - c[0]) / period_s + 0.5)) + 1
    inside = max(0, expected - len(c))
    before = max(0, int(np.floor(c[0] / period_s - 0.5 + 1e-9)))
    after = max(0, int(np.floor((duration_s - c[-1]) / period_s - 0.5 + 1e-9)))
    return inside + before + after


def longest_command_gap(command_t: np.ndarray, duration_s: float) -> float | None:
    """The longest time [s] between consecutive joint_commands of the trial window [0, duration_s] (None with
    fewer than two)."""
    c = _in_window(command_t, duration_s)
    return float(np.diff(c).max()) if len(c) >= 2 else None


def _in_window(command_t: np.ndarray, duration_s: float) -> np.ndarray:
    """The distinct command stamps [s] inside the trial window [0, duration_s], sorted."""
    c = np.unique(np.asarray(command_t, dtype=float))
    return c[(c >= 0.0) & (c <= duration_s)]


def _opt(value) -> float | None:
    return None if value is None or not np.isfinite(value) else float(value)


def trial_metrics(log: TrialLog, rule: SuccessRule | None = None, track: Tracking | None = None) -> dict:
    """Every figure of one trial as plain values (None where undefined).

    Keys: reached, tracked, success, collided, time_to_reach_s, time_to_track_s, longest_within_s,
    tracking_fraction (time within / time since first reached), final_pos_err_m, final_ori_err_deg,
    median_pos_err_after_reach_m, median_ori_err_after_reach_deg, min_obstacle_distance_m, collisions
    (contacts begun), contact_s, tick_ms_p50, tick_ms_p99, tick_ms_max, ticks_reported, commands,
    missed_ticks, command_gap_max_s, first_tick_ms, planner_states (state -> fraction of status messages),
    command_sources (status command_source -> fraction of the status messages that name one), servo_notes (why
    the IK servo declined, its figures replaced by '#' -> fraction of all status messages), planner_failures
    (distinct status messages of the "failed" state), duration_s, rule.
    """
    rule = rule or SuccessRule()
    tr = track if track is not None else tracking(log, rule)
    runs = within_runs(tr.t, tr.within, log.duration_s)
    held = [r for r in runs if r[1] - r[0] >= rule.hold_s - 1e-9]
    reached = bool(runs)
    t_reach = runs[0][0] if reached else None
    after = tr.t >= t_reach if reached else np.zeros(len(tr.t), dtype=bool)
    time_since_reach = log.duration_s - t_reach if reached else 0.0
    contact = np.asarray(log.contact, dtype=bool)
    collisions = contact_events(contact)
    contact_dt = float(np.median(np.diff(log.contact_t))) if len(log.contact_t) > 1 else 0.0
    ticks = tick_samples(log.tick_ms)
    states, counts = np.unique(np.asarray(log.status_state, dtype=str), return_counts=True)
    sources, n_source = np.unique([s for s in log.status_source if s], return_counts=True)
    return {
        "reached": reached,
        "tracked": bool(held),
        "success": bool(held) and collisions == 0,
        "collided": collisions > 0,
        "time_to_reach_s": t_reach,
        "time_to_track_s": held[0][0] if held else None,
        "longest_within_s": max((b - a for a, b in runs), default=0.0),
        "tracking_fraction": (sum(b - a for a, b in runs) / time_since_reach) if time_since_reach > 0 else 0.0,
        "final_pos_err_m": _opt(tr.pos_err_m[-1]) if len(tr.t) else None,
        "final_ori_err_deg": _opt(tr.ori_err_deg[-1]) if len(tr.t) else None,
        "median_pos_err_after_reach_m": _opt(np.median(tr.pos_err_m[after])) if after.any() else None,
        "median_ori_err_after_reach_deg": _opt(np.median(tr.ori_err_deg[after])) if after.any() else None,
        "min_obstacle_distance_m": _opt(np.min(log.distance)) if len(log.distance) else None,
        "collisions": collisions,
        "contact_s": float(np.sum(contact) * contact_dt),
        "tick_ms_p50": percentile(ticks, 50),
        "tick_ms_p99": percentile(ticks, 99),
        "tick_ms_max": _opt(np.max(ticks)) if len(ticks) else None,
        "ticks_reported": int(len(ticks)),
        "commands": int(len(np.unique(log.command_t))),
        "missed_ticks": missed_ticks(log.command_t, log.command_period_s, log.duration_s),
        "command_gap_max_s": longest_command_gap(log.command_t, log.duration_s),
        "first_tick_ms": _opt(ticks[0]) if len(ticks) else None,
        "planner_states": {str(s): float(c / counts.sum()) for s, c in zip(states, counts, strict=True)},
        "command_sources": {str(s): float(c / n_source.sum()) for s, c in zip(sources, n_source, strict=True)},
        "servo_notes": servo_note_shares(log.status_servo_note),
        "planner_failures": sorted(
            {m for s, m in zip(log.status_state, log.status_message, strict=False) if s == "failed"}
        ),
        "duration_s": float(log.duration_s),
        "rule": {"pos_tol_m": rule.pos_tol_m, "ori_tol_deg": rule.ori_tol_deg, "hold_s": rule.hold_s},
    }


def _fmt(value, scale: float = 1.0, unit: str = "", digits: int = 1) -> str:
    return "n/a" if value is None else f"{value * scale:.{digits}f}{unit}"


def format_summary(m: dict) -> str:
    """The metrics of :func:`trial_metrics` as a few human-readable lines."""
    rule = m["rule"]
    at = f"within {rule['pos_tol_m'] * 100:g} cm and {rule['ori_tol_deg']:g} deg"
    if not m["reached"]:
        verdict = f"NOT reached: the end effector never got {at} of the moving target"
    elif m["tracked"]:
        verdict = f"reached after {m['time_to_reach_s']:.1f} s and tracked ({at} for >= {rule['hold_s']:g} s)"
    else:
        verdict = (
            f"reached after {m['time_to_reach_s']:.1f} s but NOT tracked for {rule['hold_s']:g} s "
            f"(longest stretch {m['longest_within_s']:.1f} s)"
        )
    dist = m["min_obstacle_distance_m"]
    states = ", ".join(f"{s} {f:.0%}" for s, f in sorted(m["planner_states"].items(), key=lambda kv: -kv[1]))
    lines = [
        f"target           {verdict}",
        f"success          {'yes' if m['success'] else 'no'} (reached, tracked, no contact)",
        f"tracking         {m['tracking_fraction']:.0%} of the time since first reached; median error after "
        f"reach {_fmt(m['median_pos_err_after_reach_m'], 100, ' cm')}, "
        f"{_fmt(m['median_ori_err_after_reach_deg'], 1, ' deg')}; final {_fmt(m['final_pos_err_m'], 100, ' cm')}",
        f"clearance        min arm-object distance {_fmt(dist, 100, ' cm')} (ground truth from the sim)",
        f"collisions       {m['collisions']} contact(s), {m['contact_s']:.2f} s in contact",
        f"planner ticks    p50 {_fmt(m['tick_ms_p50'], 1, ' ms')}, p99 {_fmt(m['tick_ms_p99'], 1, ' ms')}, "
        f"max {_fmt(m['tick_ms_max'], 1, ' ms')}, first {_fmt(m['first_tick_ms'], 1, ' ms')} "
        f"({m['ticks_reported']} reported); {m['commands']} commands, "
        f"{m['missed_ticks']} missed periods",
        f"planner states   {states or 'no status received'}",
    ]
    lines += [f"planner failed   {reason}" for reason in m["planner_failures"][:3]]
    return "\n".join(lines)


def plot_tracking(tr: Tracking, metrics: dict | None = None, title: str = ""):
    """End effector vs target x, y, z over time and the position error (like the seed's fig. 4).

    Returns a matplotlib Figure (Agg backend).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
    for k, (ax, name) in enumerate(zip(axes[:3], "xyz", strict=True)):
        ax.plot(tr.t, tr.target_position[:, k], "--", color="tab:green", label="target")
        ax.plot(tr.t, tr.ee_position[:, k], color="tab:blue", label="end effector")
        ax.set_ylabel(f"{name} [m]")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="best", fontsize=8)
    ax = axes[3]
    ax.plot(tr.t, 100 * tr.pos_err_m, color="tab:red", label="position error")
    if metrics is not None:
        ax.axhline(100 * metrics["rule"]["pos_tol_m"], color="k", lw=0.8, ls=":", label="tolerance")
        for a in axes:
            if metrics.get("time_to_reach_s") is not None:
                a.axvline(metrics["time_to_reach_s"], color="gray", lw=0.8, ls="--")
    ax.fill_between(tr.t, 0, 1, where=tr.within, transform=ax.get_xaxis_transform(), alpha=0.15, color="tab:green")
    ax.set_ylabel("error [cm]")
    ax.set_xlabel("simulated time [s]")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def servo_note_shares(notes: tuple[str, ...]) -> dict[str, float]:
    """{kind of note: fraction of the S status messages} of why the IK servo declined, a note's figures replaced
    by '#' ("3.2 cm clearance" -> "# cm clearance"); {} without status messages."""
    kinds = Counter(re.sub(r"\d+(\.\d+)?", "#", n) for n in notes if n)
    return {k: c / len(notes) for k, c in kinds.most_common()} if notes else {}
