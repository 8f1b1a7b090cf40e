"""The settings' one rule for refusing a value: the message names the group, the field,
what it got and what it must be (``<group> field '<name>': got <v>; must be <what>``)."""
from __future__ import annotations

import math
from dataclasses import fields


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


def declared_floats(settings) -> None:
    """Store every whole number given to a field of the (frozen) dataclass ``settings``
    declared ``float`` as that float, so that 15 and 15.0 make equal settings with equal
    dicts and run keys (a YAML file writes 15 where a flag gives 15.0).  Bools and numbers
    past a float's range are left for the field's own check to refuse."""
    for f in fields(settings):
        if f.type not in ("float", float):
            continue
        v = getattr(settings, f.name)
        if isinstance(v, int) and not isinstance(v, bool):
            try:
                object.__setattr__(settings, f.name, float(v))
            except OverflowError:
                pass
