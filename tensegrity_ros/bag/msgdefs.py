"""Full ``ros2msg`` message definitions, as rosbag2 stores them in MCAP schemas.

The schema of a topic in a rosbag2 MCAP file is the type's ``.msg`` text followed by the
``.msg`` text of every type it depends on (recursively, each once). Each dependency is
preceded by a newline, a line of 80 ``=`` and a line ``MSG: pkg/Name``, where ``pkg/Name``
is the field type as written in the .msg file (types of the same package are written
``pkg/Name``). Dependencies are visited depth first, in sorted order at each level. This is
the layout rosbag2 Jazzy writes (``rosbag2_cpp`` ``LocalMessageDefinitionSource``) and the
one ``mcap-ros2-support`` and ``rosbags`` parse.

The .msg files are the ones installed with the interface packages: ``share/<pkg>/msg/*.msg``
under an install prefix. Prefixes are taken from ``AMENT_PREFIX_PATH`` when set, then from
where the package's Python module is installed, then ``sys.prefix`` (the venv, where the
PyPI ROS wheels and the suite's ``tensegrity_msgs`` put their share folders).
"""

from __future__ import annotations

import functools
import importlib.util
import os
import re
import sys
from pathlib import Path

from tensegrity_core.excerpt import excerpt
from tensegrity_ros.bag.errors import BagError

DELIMITER = "=" * 80

PRIMITIVE_TYPES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
    "int32", "uint32", "int64", "uint64", "string", "wstring",
})

# The type of a field or constant at the start of a line: "pkg/Name[] x", "Name x", "int32 X=1".
_FIELD_TYPE = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
_NAME = r"[a-zA-Z][a-zA-Z0-9_]*"
_TYPE_NAME = re.compile(rf"^({_NAME})/(?:({_NAME})/)?({_NAME})$")


def split_type_name(type_name: str) -> tuple[str, str, str]:
    """``"pkg/msg/Name"`` or ``"pkg/Name"`` -> ``(pkg, "msg", Name)``."""
    m = _TYPE_NAME.match(type_name)
    if not m:
        raise BagError(
            f"message type {excerpt(type_name)} is not of the form 'pkg/msg/Name' or 'pkg/Name'"
        )
    return m.group(1), m.group(2) or "msg", m.group(3)


def _install_prefixes(package: str) -> list[Path]:
    prefixes = [Path(p) for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    spec = importlib.util.find_spec(package) if package.isidentifier() else None
    if spec is not None and spec.origin:
        # <prefix>/lib/pythonX.Y/site-packages/<package>/__init__.py
        prefixes.append(Path(spec.origin).resolve().parents[4])
    prefixes.append(Path(sys.prefix))
    return prefixes


@functools.cache
def msg_file(type_name: str) -> Path:
    """Path of the installed ``.msg`` file of ``type_name``; :class:`BagError` if absent."""
    package, namespace, name = split_type_name(type_name)
    tried = []
    for prefix in _install_prefixes(package):
        path = prefix / "share" / package / namespace / f"{name}.msg"
        if path.is_file():
            return path
        tried.append(str(path))
    raise BagError(f"no .msg definition found for {type_name!r} (looked for {', '.join(tried)})")


def msg_dependencies(text: str, package: str) -> list[str]:
    """Non-primitive field types named in a .msg text, as ``pkg/Name``, sorted, each once."""
    deps = set()
    for m in _FIELD_TYPE.finditer(text):
        field_type = m.group(1)
        if field_type in PRIMITIVE_TYPES:
            continue
        deps.add(field_type if "/" in field_type else f"{package}/{field_type}")
    return sorted(deps)


@functools.cache
def full_definition(type_name: str) -> str:
    """The complete ``ros2msg`` definition of ``type_name`` (see the module docstring)."""
    seen: set[str] = set()

    def expand(name: str, depth: int) -> str:
        if depth > 50:
            raise BagError(f"message definition of {type_name!r} nests deeper than 50 levels")
        package = split_type_name(name)[0]
        text = msg_file(name).read_text(encoding="utf-8")
        out = text
        for dep in msg_dependencies(text, package):
            if dep not in seen:
                seen.add(dep)
                out += f"\n{DELIMITER}\nMSG: {dep}\n" + expand(dep, depth + 1)
        return out

    return expand(type_name, 0)
