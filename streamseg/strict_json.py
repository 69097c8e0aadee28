"""Strict JSON for everything streamseg prints: non-finite numbers become null, never NaN."""

from __future__ import annotations

import json
import math

import numpy as np


def finite(obj):
    """``obj`` with every NaN or infinite float (also numpy scalars, in nested dicts, lists
    and tuples) replaced by None, so strict JSON readers accept it."""
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return finite(obj.tolist())
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def dumps(obj, **kwargs) -> str:
    """``json.dumps`` of :func:`finite` ``(obj)`` with ``allow_nan=False``."""
    return json.dumps(finite(obj), allow_nan=False, **kwargs)
