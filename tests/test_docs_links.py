"""Every reference to the documentation resolves: the relative links of the README and of
``docs/`` (files, and headings for ``#anchor``), and every ``docs/<page>.md`` a README, doc,
docstring, scene or test names, with the section it quotes (``docs/robots.md``, "Gaits")
when it quotes one.

Anchors are GitHub's: the heading lower-cased, punctuation but ``-`` and ``_`` dropped,
spaces made ``-``, a repeated heading numbered ``-1``, ``-2``...
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MANUAL = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
#: Where a ``docs/<page>.md`` mention is looked for (besides the manual itself).
CODE = ("tensegrity_core", "tensegrity_ros", "studies", "tests", "docs")
CODE_SUFFIXES = (".py", ".yaml", ".yml", ".toml")

LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
#: ``docs/x.md`` or ``docs/design/x.md``, optionally followed by a quoted section title.
MENTION = re.compile(r"docs/((?:design/)?[\w-]+\.md)`?,? *(?:\"([^\"\n]+)\")?")


def headings(text: str) -> list[str]:
    """The headings of a Markdown text, outside code fences."""
    found, fence = [], False
    for line in text.splitlines():
        if line.startswith("```"):
            fence = not fence
        elif not fence and (m := re.match(r"#{1,6} (.*)", line)):
            found.append(m[1].strip())
    return found


def anchors(text: str) -> set[str]:
    """GitHub's anchors of a Markdown text's headings."""
    seen: Counter[str] = Counter()
    out = set()
    for title in headings(text):
        slug = re.sub(r"[^\w\- ]", "", title.lower()).replace(" ", "-")
        out.add(slug if not seen[slug] else f"{slug}-{seen[slug]}")
        seen[slug] += 1
    return out


def test_anchors_follow_github():
    text = "# A `b` (c), d's\n```\n# not a heading\n```\n## A `b` (c), d's\n### Fig. 2 and x_y\n"
    assert anchors(text) == {"a-b-c-ds", "a-b-c-ds-1", "fig-2-and-x_y"}


def test_every_relative_link_resolves():
    bad = []
    for page in MANUAL:
        text = page.read_text()
        for m in LINK.finditer(text):
            target = m[1]
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            file = (page.parent / path).resolve() if path else page
            where = f"{page.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}: {target}"
            if not file.is_file():
                bad.append(f"{where}: no such file")
            elif anchor and file.suffix == ".md" and anchor not in anchors(file.read_text()):
                bad.append(f"{where}: no such heading")
    assert not bad, "\n".join(bad)


def test_every_named_page_and_section_exists():
    sources = MANUAL + [p for package in CODE for p in sorted((ROOT / package).rglob("*"))
                        if p.suffix in CODE_SUFFIXES and p != Path(__file__).resolve()]
    bad = []
    for source in sources:
        text = source.read_text()
        for m in MENTION.finditer(text):
            page = ROOT / "docs" / m[1]
            where = f"{source.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}: {m[0]}"
            if not page.is_file():
                bad.append(f"{where}: no such page")
            elif m[2] and not any(h.lower().startswith(m[2].lower()) for h in headings(page.read_text())):
                bad.append(f"{where}: no such section")
    assert not bad, "\n".join(bad)
