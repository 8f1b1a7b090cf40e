"""Helpers of the golden tests (results recorded before a refactoring, compared after)."""


def exact(v):
    """Floats as repr strings (bit for bit, NaN included), recursively; tuples as lists."""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, dict):
        return {k: exact(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [exact(x) for x in v]
    return v
