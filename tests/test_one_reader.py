"""The one-reader rule (docs/architecture.md): a user's description file is parsed only by
the schema layer (``tensegrity_core/schema/``), which bounds its size and depth and locates
every error by key, line and file.

Every call and import of a parser entry point in the product and the studies is found with
:mod:`ast`, whatever name the module or function is bound to (``import yaml as y``,
``from json import load``), inside functions too.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCANNED = ("tensegrity_core", "tensegrity_ros", "studies")
SCHEMA = ROOT / "tensegrity_core" / "schema"

#: Parser entry points by module: each reads a whole document from text or a file.
PARSERS = {
    "yaml": frozenset({"load", "safe_load", "full_load", "unsafe_load", "load_all", "safe_load_all",
                       "full_load_all", "unsafe_load_all", "compose", "compose_all", "parse"}),
    "json": frozenset({"load", "loads"}),
    "tomllib": frozenset({"load", "loads"}),
    "tomli": frozenset({"load", "loads"}),
}

#: Files that parse a format the product itself writes (never a user's description), with why.
OWN_FORMATS = {
    # The sweep's results store: JSON lines the sweep engine appended; read back to resume a run.
    "tensegrity_core/sweep/store.py": {"json.loads"},
    # The metadata string a saved trajectory (.npz) carries, written by Trajectory.save.
    "tensegrity_core/sim/trajectory.py": {"json.loads"},
}


def parser_uses(source: str, where: str = "<text>") -> list[tuple[int, str]]:
    """``(line, "module.function")`` for every use of a parser entry point in ``source``."""
    tree = ast.parse(source, where)
    modules: dict[str, str] = {}          # local name -> parser module
    functions: dict[str, str] = {}        # local name -> "module.function"
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in PARSERS:
                    modules[alias.asname or alias.name] = alias.name
        elif isinstance(node, ast.ImportFrom) and node.module in PARSERS and not node.level:
            for alias in node.names:
                if alias.name in PARSERS[node.module]:
                    functions[alias.asname or alias.name] = f"{node.module}.{alias.name}"
                    found.append((node.lineno, f"{node.module}.{alias.name}"))
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in modules
                and node.attr in PARSERS[modules[node.value.id]]):
            found.append((node.lineno, f"{modules[node.value.id]}.{node.attr}"))
        elif isinstance(node, ast.Name) and node.id in functions and isinstance(node.ctx, ast.Load):
            found.append((node.lineno, functions[node.id]))
    return sorted(set(found))


def test_the_finder_sees_every_way_of_naming_a_parser():
    source = (
        "import yaml as y, json\n"
        "from tomllib import loads as tl\n"
        "def f(text):\n"
        "    y.safe_load(text); json.load(open(text)); tl(text)\n"
        "    json.dumps({}); y.safe_dump({})\n"
    )
    assert parser_uses(source) == [(2, "tomllib.loads"), (4, "json.load"), (4, "tomllib.loads"),
                                   (4, "yaml.safe_load")]


def test_only_the_schema_layer_parses_description_files():
    bad = []
    for package in SCANNED:
        for path in sorted((ROOT / package).rglob("*.py")):
            if path.is_relative_to(SCHEMA):
                continue
            name = str(path.relative_to(ROOT))
            allowed = OWN_FORMATS.get(name, set())
            bad += [f"{name}:{line}: {use}" for line, use in parser_uses(path.read_text(), name) if use not in allowed]
    assert not bad, ("read description files with tensegrity_core.schema (read_file, parse_text, read_text) "
                     "and check them with a schema.Reader:\n" + "\n".join(bad))


def test_every_exception_to_the_rule_is_still_needed():
    for name, allowed in OWN_FORMATS.items():
        assert {use for _, use in parser_uses((ROOT / name).read_text(), name)} == allowed, name
