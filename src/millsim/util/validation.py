"""Input validation that names the offending key and its allowed range."""

import math

import numpy as np


def check_range(key, value, lo=None, hi=None, lo_open=False, hi_open=False):
    """Raise ValueError naming ``key`` unless lo (<|<=) value (<|<=) hi."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{key}: must be a number, got {value!r}") from None
    bad = math.isnan(value)
    if lo is not None:
        bad |= value <= lo if lo_open else value < lo
    if hi is not None:
        bad |= value >= hi if hi_open else value > hi
    if bad:
        left = "(" if lo_open or lo is None else "["
        right = ")" if hi_open or hi is None else "]"
        lo_s = "-inf" if lo is None else f"{lo:g}"
        hi_s = "inf" if hi is None else f"{hi:g}"
        raise ValueError(f"{key}: {value:g} is outside the allowed range {left}{lo_s}, {hi_s}{right}")
    return value


def unit_vector(key, v):
    """``v`` (3 numbers) scaled to unit length; ValueError naming ``key`` for a zero vector."""
    v = np.asarray(v, dtype=float).reshape(3)
    norm = np.linalg.norm(v)
    if norm == 0:
        raise ValueError(f"{key}: must be a non-zero vector")
    return v / norm
