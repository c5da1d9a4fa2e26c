"""Structures to descriptions: plain data, YAML text, and files in every structure format.

- :func:`structure_to_dict`: the per-member form (one mapping per member, node names).
- :func:`structure_to_arrays`: the array form (node coordinates as a list, members as
  columns of node positions and values), for generated structures.
- :func:`dump_structure`: YAML text in the hand-written style, one node or member a line
  (:func:`dump_description`: the same style for any description's plain data).
- :func:`save_structure`: a file by its suffix: ``.yaml``/``.yml`` (per member), ``.json``
  (array form), ``.npz`` (arrays, :mod:`~tensegrity_core.general.structure_npz`).

Every writer's output reads back into an equal structure (``structure_from_file``).
YAML scalars are written here rather than by ``yaml.safe_dump`` (which took 50 s for a
60,000-member structure, one call per line): strings stay plain only when they read back
as the same string, otherwise they are double-quoted (JSON's quoting, which YAML reads);
floats keep a dot in the mantissa (``1.0e-05``) so that YAML 1.1 readers read numbers.
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path
from typing import Any, Final

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.structure import Structure, StructureError
from tensegrity_core.schema.yaml_reader import plain_scalar_tag

_PLAIN: Final = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*\Z")


def structure_to_dict(structure: Structure) -> dict[str, Any]:
    """The description of ``structure`` as plain data (absolute rest lengths, EA per member);
    ``load_structure(structure_to_dict(s))`` rebuilds an equal structure."""
    s = structure
    names = s.node_names
    out: dict[str, Any] = {"name": s.name, "units": "SI",
                           "nodes": {n: xyz for n, xyz in zip(names, s.nodes.tolist())}}
    ends, EA, l0, mass = s.members.tolist(), s.EA.tolist(), s.rest_lengths.tolist(), s.member_masses.tolist()
    members: list[dict[str, Any]] = []
    for i, name in enumerate(s.member_names):
        a, b = ends[i]
        m: dict[str, Any] = {"name": name, "nodes": [names[a], names[b]], "type": s.member_kinds[i], "EA": EA[i],
             "rest_length": l0[i]}
        if mass[i]:
            m["mass"] = mass[i]
        members.append(m)
    out["members"] = members
    out.update(_supports_and_loads(s))
    return out


def structure_to_arrays(structure: Structure) -> dict[str, Any]:
    """The array form of ``structure`` (``docs/structures.md``): node coordinates as a list
    (with ``node_names`` unless they are "0", "1", ...), members as columns of node
    positions, kinds, EA, rest lengths (and names and masses where they are not defaults)."""
    s = structure
    out: dict[str, Any] = {"name": s.name, "units": "SI", "nodes": s.nodes.tolist()}
    if s.node_names != tuple(str(i) for i in range(s.n_nodes)):
        out["node_names"] = list(s.node_names)
    kinds = set(s.member_kinds)
    members: dict[str, Any] = {"nodes": s.members.tolist(),
                     "type": s.member_kinds[0] if len(kinds) == 1 else list(s.member_kinds),
                     "EA": _column(s.EA), "rest_length": s.rest_lengths.tolist()}
    if s.member_names != tuple(f"m{i}" for i in range(s.n_members)):
        members["name"] = list(s.member_names)
    if s.member_masses.any():
        members["mass"] = _column(s.member_masses)
    out["members"] = members
    out.update(_supports_and_loads(s))
    return out


def _column(values: NDArray[np.float64]) -> float | list[float]:
    return float(values[0]) if (values == values[0]).all() else values.tolist()


def _supports_and_loads(s: Structure) -> dict[str, Any]:
    out: dict[str, Any] = {}
    names = s.node_names
    pinned_rows = np.flatnonzero(s.pinned.any(axis=1))
    if pinned_rows.size:
        out["pinned"] = {names[i]: "".join("xyz"[j] for j in range(3) if s.pinned[i, j]) for i in pinned_rows}
    if s.bodies:
        out["rigid_bodies"] = []
        for body in s.bodies:
            entry: dict[str, Any] = {"name": body.name, "nodes": [names[i] for i in body.nodes]}
            if body.mass:
                entry["mass"] = float(body.mass)
            if body.fixed:
                entry["fixed"] = True
            out["rigid_bodies"].append(entry)
    loaded = np.flatnonzero(s.loads.any(axis=1))
    if loaded.size:
        out["loads"] = {names[i]: s.loads[i].tolist() for i in loaded}
    heavy = np.flatnonzero(s.node_masses)
    if heavy.size:
        out["masses"] = {names[i]: float(s.node_masses[i]) for i in heavy}
    if s.gravity.any():
        out["gravity"] = s.gravity.tolist()
    return out


def dump_structure(structure: Structure, header: str = "") -> str:
    """YAML text of ``structure`` in the hand-written style (one node or member per line),
    preceded by ``header`` as comment lines."""
    return dump_description(structure_to_dict(structure), header)


def dump_description(data: dict[str, Any], header: str = "") -> str:
    """YAML text of a description's plain ``data`` in the hand-written style: each top-level
    mapping one entry a line, each list of mappings (or of lists) one item a line, everything
    else in flow style; preceded by ``header`` as comment lines."""
    lines = [f"# {h}" if h else "#" for h in header.splitlines()]
    for key, value in data.items():
        if isinstance(value, dict):
            lines.append(f"{key}:")
            lines += [f"  {_flow(k)}: {_flow(v)}" for k, v in value.items()]
        elif isinstance(value, list) and value and isinstance(value[0], (dict, list)):
            lines.append(f"{key}:")
            lines += [f"  - {_flow(v)}" for v in value]
        else:
            lines.append(f"{key}: {_flow(value)}")
    return "\n".join(lines) + "\n"


def _flow(value: object) -> str:
    """``value`` (str, number, bool, None, list, dict) as one line of YAML flow style."""
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return _float(value)
    if value is None:
        return "null"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_flow(k)}: {_flow(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(map(_flow, value)) + "]"
    raise StructureError(f"cannot write a {type(value).__name__} as YAML")


def _string(text: str) -> str:
    if _PLAIN.match(text) and plain_scalar_tag(text) == "tag:yaml.org,2002:str":
        return text
    return json.dumps(text, ensure_ascii=False)


def _float(x: float) -> str:
    if not math.isfinite(x):
        return ".nan" if math.isnan(x) else (".inf" if x > 0 else "-.inf")
    text = repr(x)
    mantissa, e, exponent = text.partition("e")
    if e and "." not in mantissa:
        return f"{mantissa}.0e{exponent}"
    return text


def save_structure(structure: Structure, path: str | os.PathLike[str]) -> Path:
    """Write ``structure`` to ``path`` in the format of its suffix (``.yaml``/``.yml``,
    ``.json``, ``.npz``) and return the path."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        from tensegrity_core.general.structure_npz import write_npz

        write_npz(structure, path)
    elif suffix == ".json":
        path.write_text(json.dumps(structure_to_arrays(structure), separators=(",", ":")) + "\n")
    elif suffix in (".yaml", ".yml"):
        path.write_text(dump_structure(structure))
    else:
        raise StructureError(f"cannot tell the format of {str(path)!r}: use .yaml, .yml, .json or .npz")
    return path
