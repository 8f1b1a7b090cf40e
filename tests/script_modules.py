"""The project's scripts (scripts/, benchmarks/) as modules, for the tests of their
functions."""
from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).parents[1]


def load_script(name: str, folder: str = "scripts"):
    """``<folder>/<name>.py`` of the project imported as a module named ``name``."""
    spec = importlib.util.spec_from_file_location(name, ROOT / folder / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
