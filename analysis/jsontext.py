"""JSON as gasfilm prints and writes it: strict JSON, which has no NaN or Infinity — a number that is not finite (an
uncertainty that could not be estimated, an error that overflowed) is written as null."""

from __future__ import annotations

import json
import math
from typing import Any


def finite(value: Any) -> Any:
    """``value`` with every non-finite float replaced by None (NumPy numbers and arrays as plain ones)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: finite(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite(item) for item in value]
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):  # NumPy scalars and arrays
        return finite(value.tolist())
    return value


def dumps(value: Any, **options: Any) -> str:
    """Strict JSON text of ``value`` (:func:`finite` first; options as ``json.dumps``)."""
    return json.dumps(finite(value), allow_nan=False, **options)
