"""Small modules with one job each: a module of the product over 500 lines says at the top
why it is one module (its docstring has a paragraph starting "Longer than 500 lines
because"), else it is split by concept."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("tensegrity_core", "tensegrity_ros", "studies")
MAX_LINES = 500
REASON = "Longer than 500 lines because"

#: Modules whose split belongs to work under way elsewhere, with where.
SPLIT_ELSEWHERE = {
}


def test_a_long_module_says_why_it_is_one():
    bad = []
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            name = str(path.relative_to(ROOT))
            text = path.read_text()
            lines = text.count("\n")
            if lines <= MAX_LINES or name in SPLIT_ELSEWHERE:
                continue
            doc = ast.get_docstring(ast.parse(text, name)) or ""
            if not any(paragraph.startswith(REASON) for paragraph in doc.split("\n\n")):
                bad.append(f"{name}: {lines} lines")
    assert not bad, f"split these by concept, or say why not in a docstring paragraph '{REASON} ...':\n" + "\n".join(bad)
