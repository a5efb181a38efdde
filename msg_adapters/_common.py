"""Small helpers shared by the adapters: stamps, durations, array validation."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Duration, Time

from msg_adapters.errors import AdapterError

NS_PER_S = 1_000_000_000


def stamp_or_zero(stamp: Time | None) -> Time:
    """The given builtin_interfaces/Time, or a zero time (0 s) when None."""
    if stamp is None:
        return Time()
    if not isinstance(stamp, Time):
        raise AdapterError(f"stamp must be a builtin_interfaces/Time or None, got {type(stamp).__name__}")
    return stamp


def seconds_to_duration(t_s: float) -> Duration:
    """Seconds (finite, >= 0) -> builtin_interfaces/Duration, rounded to the nanosecond."""
    total_ns = round(float(t_s) * NS_PER_S)
    return Duration(sec=int(total_ns // NS_PER_S), nanosec=int(total_ns % NS_PER_S))


def duration_to_seconds(d: Duration) -> float:
    """builtin_interfaces/Duration -> seconds [s]."""
    return d.sec + d.nanosec * 1e-9


def as_float_array(value, shape: tuple[int | None, ...], what: str) -> np.ndarray:
    """`value` as a finite float64 array of the given shape (None = any length); AdapterError otherwise."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise AdapterError(f"{what}: not a numeric array ({exc})") from exc
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape, strict=True)):
        expected = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"
        raise AdapterError(f"{what}: expected shape {expected}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise AdapterError(f"{what}: contains NaN or inf")
    return arr
