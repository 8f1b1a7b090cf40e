"""The settings' one rule for refusing a value: the message names the group, the field,
what it got and what it must be (``<group> field '<name>': got <v>; must be <what>``)."""
from __future__ import annotations

import math


def check_choice(group: str, name: str, value, allowed, error) -> None:
    """Raise ``error`` unless ``value`` is one of ``allowed``."""
    if value not in allowed:
        raise error(f"{group} field '{name}': got {value!r}; must be one of "
                    f"{', '.join(allowed)}")


def check_numbers(group: str, settings, limits: dict, error) -> None:
    """Raise ``error`` for the first field of ``limits`` (name -> (low, high, words)) whose
    value in ``settings`` is not a finite number in [low, high]."""
    for name, (lo, hi, what) in limits.items():
        v = getattr(settings, name)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) \
                or not lo <= v <= hi:
            raise error(f"{group} field '{name}': got {v!r}; must be {what}")


def finite_numbers(value) -> tuple | None:
    """``value`` (a sequence of numbers: a list, a tuple, an array) as a tuple of floats, or
    None when it is not one, or holds a NaN or an infinity; the caller checks the length
    and names the field."""
    if isinstance(value, (str, bytes)):
        return None
    try:
        t = tuple(float(c) for c in value)
    except (TypeError, ValueError):
        return None
    return t if all(math.isfinite(c) for c in t) else None
