"""Checks of a public function's arguments at its boundary: each raises ``ArgumentError`` (a ``GantryError``
and a ``TypeError``) naming the argument, before anything is computed with it.

May import: ``plant.errors``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path

from plant.errors import ArgumentError, ParameterError


def check_path(name: str, value) -> Path:
    """``value`` as a ``Path``: a ``str`` or ``os.PathLike``, else ``ArgumentError``."""
    if isinstance(value, str | os.PathLike) and not isinstance(value, bytes):
        return Path(value)
    raise ArgumentError(f"{name} must be a file path (str or pathlib.Path), got {type(value).__name__} {value!r}")


def check_optional_text(name: str, value) -> str | None:
    """``value`` when it is None or a ``str``, else ``ArgumentError``."""
    if value is None or isinstance(value, str):
        return value
    raise ArgumentError(f"{name} must be a string or None, got {type(value).__name__} {value!r}")


def check_names(name: str, value) -> tuple[str, ...]:
    """``value`` as a tuple of strings: a list or tuple of ``str`` (a bare string is refused: ``("delay",)``,
    not ``"delay"``, which would read as its letters)."""
    if isinstance(value, str) or not isinstance(value, Sequence) or not all(isinstance(v, str) for v in value):
        raise ArgumentError(f"{name} must be a list or tuple of names, e.g. ('delay',), got {value!r}")
    return tuple(value)


def check_instance(name: str, value, kind: type, how: str):
    """``value`` when it is a ``kind``, else ``ArgumentError`` saying ``how`` to get one."""
    if isinstance(value, kind):
        return value
    raise ArgumentError(f"{name} must be a {kind.__name__} ({how}), got {type(value).__name__} {value!r}"[:300])


def check_number(name: str, value, *, minimum: float = -math.inf) -> float:
    """``value`` as a float: a real number (not a bool or string), finite and >= ``minimum``."""
    import numpy as np

    if isinstance(value, bool | str | bytes) or np.ndim(value) != 0 \
            or np.asarray(value).dtype.kind not in "iuf":
        raise ArgumentError(f"{name} must be a real number, got {type(value).__name__} {value!r}")
    v = float(value)
    if not math.isfinite(v) or v < minimum:
        bound = f" and >= {minimum:g}" if minimum > -math.inf else ""
        raise ParameterError(f"{name} must be finite{bound}, got {value!r}")
    return v


def check_count(name: str, value, *, minimum: int = 0) -> int:
    """``value`` as an int: an integer (not a bool, not a float) >= ``minimum``."""
    import numpy as np

    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ArgumentError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    if value < minimum:
        raise ParameterError(f"{name} must be >= {minimum}, got {value}")
    return int(value)


def check_values(name: str, value) -> dict[str, float]:
    """``value`` (None: empty) as a dict of parameter name -> finite real number."""
    from collections.abc import Mapping

    if value is None:
        return {}
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise ArgumentError(f"{name} must be a dict of parameter name -> number, e.g. {{'mass_kg': 40.0}}, got "
                            f"{type(value).__name__} {value!r}"[:300])
    return {k: check_number(f"{name}[{k!r}]", v) for k, v in value.items()}
