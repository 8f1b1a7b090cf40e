"""The documentation's relative links lead somewhere: every link of README.md and the
Markdown files under docs/ to a file of the repository names one that exists, and a
``#fragment`` names a heading of its target as GitHub slugs it (lower case; characters
other than letters, digits, spaces, '-' and '_' dropped; spaces to '-'; a repeated heading
gains -1, -2, ...).  A heading renamed without its links fails here."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$")
FENCE = re.compile(r"^\s*(```|~~~)")


def _docs() -> list[Path]:
    return [ROOT / "README.md", ROOT / "CHANGELOG.md"] + sorted((ROOT / "docs").rglob("*.md"))


def _lines_outside_code(text: str):
    fenced = False
    for line in text.splitlines():
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            yield line


def slug(heading: str) -> str:
    """GitHub's anchor of a heading's text (inline code and emphasis marks dropped)."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)      # a link keeps its text
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    text = path.read_text(encoding="utf-8")
    for line in _lines_outside_code(text):
        m = HEADING.match(line)
        if not m:
            continue
        base = slug(m.group(1))
        k = seen.get(base, 0)
        seen[base] = k + 1
        out.add(base if k == 0 else f"{base}-{k}")
    out.update(re.findall(r"<a\s+(?:name|id)=\"([^\"]+)\"", text))
    return out


def test_slug_follows_github():
    assert slug("Case 1 for a tumbling target (2 deg/s flat spin): 7.32 kg, validated twice") \
        == "case-1-for-a-tumbling-target-2-degs-flat-spin-732-kg-validated-twice"
    assert slug("Findings (issue 19, point 5; the flat axis complete)") \
        == "findings-issue-19-point-5-the-flat-axis-complete"
    assert slug("`tethernet study` and P*_s") == "tethernet-study-and-p_s"


@pytest.mark.parametrize("doc", _docs(), ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc):
    broken = []
    for line in _lines_outside_code(doc.read_text(encoding="utf-8")):
        for target in LINK.findall(line):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):       # http:, https:, mailto:
                continue
            path, _, frag = target.partition("#")
            dest = doc if not path else (doc.parent / path).resolve()
            if not dest.exists():
                broken.append(f"{target}: no file {dest.relative_to(ROOT) if dest.is_relative_to(ROOT) else dest}")
            elif frag and dest.suffix == ".md" and frag not in anchors(dest):
                broken.append(f"{target}: no heading with anchor #{frag} in "
                              f"{dest.relative_to(ROOT)}")
    assert not broken, "\n".join(broken)
