"""docs/layout.md names every module and script (issue 54: it had left out a dozen
modules and seven scripts): each file of tethernet_ros/, optimizer/ (but packages'
__init__.py) and scripts/ appears in it by its file name or its module name."""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def unnamed(text: str) -> list[str]:
    missing = []
    for pkg in ("tethernet_ros", "optimizer"):
        for path in sorted((ROOT / pkg).rglob("*.py")):
            if "__pycache__" in path.parts or path.name == "__init__.py":
                continue
            if path.name not in text and path.stem not in text:
                missing.append(str(path.relative_to(ROOT)))
    for path in sorted((ROOT / "scripts").iterdir()):
        if path.is_file() and path.name not in text:
            missing.append(str(path.relative_to(ROOT)))
    return missing


def test_layout_names_every_module_and_script():
    missing = unnamed((ROOT / "docs" / "layout.md").read_text())
    assert not missing, "docs/layout.md does not name: " + ", ".join(missing)


def test_a_module_left_out_is_found():
    text = (ROOT / "docs" / "layout.md").read_text().replace("tug_trace.py", "")
    assert "scripts/tug_trace.py" in unnamed(text)
