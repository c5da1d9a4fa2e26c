"""The ``.npz`` structure format: a structure as numpy arrays, for large generated ones.

A NumPy ``.npz`` archive (``numpy.savez``) with these arrays (``n`` nodes, ``m`` members,
``b`` rigid bodies); SI units, the conventions of :class:`Structure`:

=================  ============  =====================================================
``format``         ()  str       ``"tensegrity-structure/1"``
``name``           ()  str       the structure's name
``nodes``          (n, 3) float  reference coordinates [m]
``node_names``     (n,) str      optional; default "0", "1", ...
``members``        (m, 2) int    node positions of each member's ends (from 0)
``member_names``   (m,) str      optional; default "m0", "m1", ...
``member_kinds``   (m,) uint8    0 bar, 1 string, 2 actuator (``MEMBER_KINDS`` order)
``EA``             (m,) float    axial stiffness [N]
``rest_lengths``   (m,) float    [m]
``member_masses``  (m,) float    optional [kg]; default 0
``pinned``         (n, 3) bool   optional; pinned axes
``loads``          (n, 3) float  optional [N]
``node_masses``    (n,) float    optional [kg]
``gravity``        (3,) float    optional [m/s^2]
``body_names``     (b,) str      rigid bodies (all five or none): names,
``body_sizes``     (b,) int      number of nodes of each body,
``body_nodes``     (sum,) int    their node positions, body after body,
``body_masses``    (b,) float    masses [kg],
``body_fixed``     (b,) bool     and whether each is fixed
=================  ============  =====================================================

Reading never unpickles (``allow_pickle=False``) and checks every array's header (shape
and type) against the bounds before reading its data: a file cannot make the reader
allocate more than ``Limits.max_bytes`` or read anything but plain numbers and strings.
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Final, TypeAlias

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.general.structure import MEMBER_KINDS, RigidBody, Structure, StructureError
from tensegrity_core.schema import DEFAULT_LIMITS, Limits, excerpt

FORMAT: Final = "tensegrity-structure/1"
REQUIRED: Final = ("format", "nodes", "members", "member_kinds", "EA", "rest_lengths")
OPTIONAL: Final = ("name", "node_names", "member_names", "member_masses", "pinned", "loads", "node_masses",
            "gravity", "body_names", "body_sizes", "body_nodes", "body_masses", "body_fixed")
_BODY: Final = ("body_names", "body_sizes", "body_nodes", "body_masses", "body_fixed")
_KINDS: Final = {"f": "a float", "i": "an integer", "u": "an integer", "b": "a boolean", "U": "a string"}

#: The arrays of a file by name.
Arrays: TypeAlias = Mapping[str, NDArray[Any]]


def write_npz(structure: Structure, path: str | os.PathLike[str]) -> None:
    """Write ``structure`` to ``path`` (.npz)."""
    s = structure
    arrays: dict[str, NDArray[Any]] = {"format": np.array(FORMAT), "name": np.array(s.name), "nodes": s.nodes, "members": s.members,
              "member_kinds": np.array([MEMBER_KINDS.index(k) for k in s.member_kinds], dtype=np.uint8),
              "EA": s.EA, "rest_lengths": s.rest_lengths}
    if s.node_names != tuple(str(i) for i in range(s.n_nodes)):
        arrays["node_names"] = np.array(s.node_names)
    if s.member_names != tuple(f"m{i}" for i in range(s.n_members)):
        arrays["member_names"] = np.array(s.member_names)
    for key in ("member_masses", "pinned", "loads", "node_masses", "gravity"):
        if getattr(s, key).any():
            arrays[key] = getattr(s, key)
    if s.bodies:
        arrays.update(body_names=np.array([b.name for b in s.bodies]),
                      body_sizes=np.array([len(b.nodes) for b in s.bodies], dtype=np.int64),
                      body_nodes=np.array([i for b in s.bodies for i in b.nodes], dtype=np.int64),
                      body_masses=np.array([b.mass for b in s.bodies], dtype=float),
                      body_fixed=np.array([b.fixed for b in s.bodies], dtype=bool))
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)  # type: ignore[arg-type]  # numpy's stubs: a **mapping might fill allow_pickle


def read_npz(path: str | os.PathLike[str], *, limits: Limits = DEFAULT_LIMITS, max_members: int | None = None) -> Structure:
    """The structure in the ``.npz`` file ``path``; errors name the file and the array."""
    file = Path(path)
    try:
        return _read(file, limits, max_members)
    except StructureError as err:
        raise err.located(file=file.name) from None


def _read(path: Path, limits: Limits, max_members: int | None) -> Structure:
    shapes = _headers(path, limits)
    missing = [k for k in REQUIRED if k not in shapes]
    if missing:
        raise StructureError(f"not a structure file: no array {', '.join(missing)} (a structure .npz has "
                             f"{', '.join(REQUIRED)})")
    unknown = sorted(set(shapes) - set(REQUIRED) - set(OPTIONAL))
    if unknown:
        raise StructureError(f"unknown array {excerpt(unknown[0])}; arrays: {', '.join(REQUIRED + OPTIONAL)}")
    m = shapes["members"][0][0] if shapes["members"][0] else 0
    if max_members is not None and m > max_members:
        raise StructureError(f"the structure has {m} members, more than the limit of {max_members}",
                             entry=("members",))
    with np.load(path, allow_pickle=False) as npz:
        a = {key: npz[key] for key in shapes}
    if str(a["format"]) != FORMAT:
        raise StructureError(f"format is {excerpt(str(a['format']))}, not {FORMAT!r}")
    n = _array(a, "nodes", "f", 2).shape[0]
    _shape(a, "nodes", (n, 3))
    _shape(a, "members", (m, 2), "i")
    for key, shape, kind in (("member_kinds", (m,), "u"), ("EA", (m,), "f"), ("rest_lengths", (m,), "f"),
                             ("member_masses", (m,), "f"), ("pinned", (n, 3), "b"), ("loads", (n, 3), "f"),
                             ("node_masses", (n,), "f"), ("gravity", (3,), "f"), ("node_names", (n,), "U"),
                             ("member_names", (m,), "U")):
        if key in a:
            _shape(a, key, shape, kind)
    codes = a["member_kinds"]
    if codes.size and int(codes.max()) >= len(MEMBER_KINDS):
        i = int(np.flatnonzero(codes >= len(MEMBER_KINDS))[0])
        raise StructureError(f"member_kinds[{i}] is {int(codes[i])}; kinds are 0 bar, 1 string, 2 actuator",
                             entry=("members", i))
    kind_names = np.array(MEMBER_KINDS)[codes]
    return Structure(
        name=str(a["name"]) if "name" in a else path.stem,
        node_names=tuple(a["node_names"].tolist()) if "node_names" in a else tuple(str(i) for i in range(n)),
        nodes=a["nodes"], members=a["members"].astype(np.int64),
        member_names=tuple(a["member_names"].tolist()) if "member_names" in a else tuple(f"m{i}" for i in range(m)),
        member_kinds=tuple(kind_names.tolist()), EA=a["EA"], rest_lengths=a["rest_lengths"],
        member_masses=a.get("member_masses", np.zeros(m)), pinned=a.get("pinned", np.zeros((n, 3), dtype=bool)),
        bodies=_bodies(a, n), loads=a.get("loads", np.zeros((n, 3))), node_masses=a.get("node_masses", np.zeros(n)),
        gravity=a.get("gravity", np.zeros(3)))


#: Shape and dtype of an array, from its header.
Header: TypeAlias = tuple[tuple[int, ...], np.dtype[Any]]


def _headers(path: Path, limits: Limits) -> dict[str, Header]:
    """Array name -> (shape, dtype) from each member's header, without reading the data;
    the file and the total of the arrays are bounded by ``limits.max_bytes``."""
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise StructureError(f"file not found: {excerpt(str(path))}") from None
    except OSError as err:
        raise StructureError(f"cannot read {excerpt(str(path))}: {err.strerror}") from None
    if size > limits.max_bytes:
        raise StructureError(f"the file is {size} bytes, more than the limit of {limits.max_bytes}")
    out: dict[str, Header] = {}
    total = 0
    try:
        with zipfile.ZipFile(path) as zf:
            for info in zf.infolist():
                key = info.filename.removesuffix(".npy")
                with zf.open(info) as fh:
                    version = np.lib.format.read_magic(fh)
                    shape, _, dtype = (np.lib.format.read_array_header_1_0(fh) if version == (1, 0)
                                       else np.lib.format.read_array_header_2_0(fh))
                if dtype.hasobject or dtype.kind not in "fiubU":
                    raise StructureError(f"array {excerpt(key)} holds {dtype}, not plain numbers or strings")
                nbytes = int(np.prod(shape, dtype=object)) * dtype.itemsize
                total += nbytes
                if nbytes > info.file_size or total > limits.max_bytes:
                    raise StructureError(f"array {excerpt(key)} of shape {shape} is larger than its file entry "
                                         f"or than the limit of {limits.max_bytes} bytes")
                out[key] = (shape, dtype)
    except StructureError:
        raise
    except (zipfile.BadZipFile, ValueError, EOFError, OSError) as err:
        raise StructureError(f"not a readable .npz file: {excerpt(str(err))}") from None
    return out


def _array(a: Arrays, key: str, kind: str, ndim: int) -> NDArray[Any]:
    arr = a[key]
    if arr.dtype.kind not in (kind + "iu" if kind == "f" else kind) or arr.ndim != ndim:
        raise StructureError(f"array {key} must be {ndim}-dimensional, {_KINDS[kind]}; got shape {arr.shape} "
                             f"of {arr.dtype}", entry=(key,))
    return arr


def _shape(a: Arrays, key: str, shape: tuple[int, ...], kind: str = "f") -> None:
    arr = a[key]
    ok_kind = arr.dtype.kind in {"f": "fiu", "i": "iu", "u": "u", "b": "b", "U": "U"}[kind]
    if arr.shape != shape or not ok_kind:
        raise StructureError(f"array {key} must have shape {shape} and hold {_KINDS[kind]} values, got shape "
                             f"{arr.shape} of {arr.dtype}", entry=(key,))


def _bodies(a: Arrays, n: int) -> tuple[RigidBody, ...]:
    present = [k for k in _BODY if k in a]
    if not present:
        return ()
    if len(present) != len(_BODY):
        raise StructureError(f"rigid bodies need all of {', '.join(_BODY)}; missing "
                             f"{', '.join(k for k in _BODY if k not in a)}", entry=("rigid_bodies",))
    b = len(a["body_names"])
    for key, kind in (("body_names", "U"), ("body_sizes", "i"), ("body_masses", "f"), ("body_fixed", "b")):
        _shape(a, key, (b,), kind)
    sizes = a["body_sizes"]
    if (sizes < 0).any() or int(sizes.sum()) != a["body_nodes"].size:
        raise StructureError("body_sizes must add up to the length of body_nodes", entry=("rigid_bodies",))
    _shape(a, "body_nodes", (int(sizes.sum()),), "i")
    flat, ends = a["body_nodes"].tolist(), np.cumsum(sizes).tolist()
    return tuple(RigidBody(name, tuple(flat[end - size:end]), mass, fixed) for name, end, size, mass, fixed in zip(
        a["body_names"].tolist(), ends, sizes.tolist(), a["body_masses"].tolist(), a["body_fixed"].tolist()))
