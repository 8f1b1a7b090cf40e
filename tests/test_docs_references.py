"""The docstrings' cross-references lead somewhere: every ``:func:``, ``:meth:``,
``:class:``, ``:mod:``, ``:data:`` and ``:attr:`` reference in tethernet_ros/ and
optimizer/ names an object that exists (issue 54: ``optimizer/selection.py`` cited a
function that did not).  A name resolves as written (absolute, or relative with leading
dots to the module's package), in its module, in a sibling module, or as an attribute of
a class defined in its module (``:meth:`ask``` inside a class).  A function renamed
without its references fails here."""
from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REF = re.compile(r":(?:func|meth|class|mod|data|attr):`~?([A-Za-z_.][\w.]*)`")
#: modules that need the ROS wheels or a display to import (checked where they import)
PACKAGES = ("tethernet_ros", "optimizer")


def _modules():
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            if "__pycache__" in path.parts:
                continue
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            yield ".".join(parts), path


def _lookup(parts: list[str]) -> bool:
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for a in parts[i:]:
            if not hasattr(obj, a):
                break
            obj = getattr(obj, a)
        else:
            return True
    return False


def resolves(name: str, modname: str, is_package: bool) -> bool:
    """Whether the reference ``name`` in module ``modname`` names an existing object."""
    here = modname.split(".")
    package = here if is_package else here[:-1]
    if name.startswith("."):
        lead = len(name) - len(name.lstrip("."))
        base = package[:len(package) - (lead - 1)] if lead > 1 else package
        return _lookup(base + name.lstrip(".").split("."))
    parts = name.split(".")
    candidates = [parts, here + parts, package + parts]
    module = importlib.import_module(modname)
    candidates += [here + [v.__name__] + parts for v in vars(module).values()
                   if isinstance(v, type) and v.__module__ == modname]
    return any(_lookup(c) for c in candidates)


def test_docstring_references_resolve():
    bad = []
    for modname, path in _modules():
        try:
            importlib.import_module(modname)
        except ImportError as exc:
            if "rclpy" in str(exc) or "tethernet_msgs" in str(exc):
                continue                    # a ROS module without the wheels: its own tests
            raise
        for m in REF.finditer(path.read_text()):
            if not resolves(m.group(1), modname, path.name == "__init__.py"):
                line = path.read_text()[:m.start()].count("\n") + 1
                bad.append(f"{path.relative_to(ROOT)}:{line}: {m.group(0)}")
    assert not bad, "references to nothing:\n" + "\n".join(bad)


def test_a_reference_to_nothing_is_found():
    """The check can fail: a made-up name does not resolve, a real one does."""
    assert resolves("optimizer.finish.selection_level", "optimizer.selection", False)
    assert not resolves("optimizer.finish.validation_pass_level", "optimizer.selection", False)
    assert resolves(".keys.run_key", "tethernet_ros.montecarlo.evaluate", False)
    with pytest.raises(AssertionError):
        assert resolves("no_such_thing", "tethernet_ros.core.tug", False)
