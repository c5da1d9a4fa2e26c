"""Sweep files: read, check and turn into a :class:`Sweep` (the format is in docs/sweeps.md).

::

    name: fold_time_kc                      # optional; default: the file name
    description: free text                  # optional
    base: {scene: paper_fold}               # or {structure: spine_c}: shipped name or file
    vary:                                   # key path into the base -> values
      model.params.k: {grid: {from: 0.5, to: 3.0, num: 11}}      # spacing: linear | log
      model.params.c: {values: [0.0, 0.01, 0.1]}
      members[side*].rest_length: {normal: {mean: 1.0, std: 0.05}, scale: true, name: side}
    samples: 200                            # points per grid point, with random quantities
    seed: 0                                 # random values and each point's seed
    compute: simulate                       # or {form_find: {method: newton}}, stiffness, {ik: {targets: ...}}
    results: [t_end, {first_event_time: {kind: fold}}]

Every problem raises :class:`~tensegrity_core.sweep.errors.SweepError` naming the key path
and the line: unknown keys (with a suggestion), wrong types, key paths that lead nowhere in
the base, computations that do not fit the base, unknown results and options. What a point's
values do to the base is not checked here: each point's document goes through the core's
loader on a worker, and a bad value becomes that point's row with the loader's message.

This module carries its own small checks of the sweep file (the scene and structure readers
have theirs); it reads YAML with the structure loader's line-keeping parser.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tensegrity_core.schema import KeyPath, ShippedFiles, suggest, type_name
from tensegrity_core.sweep.base import BASE_KINDS, Base, BaseError, load_base, plain
from tensegrity_core.sweep.checks import Check, OptionError
from tensegrity_core.sweep.checks import number as number_check
from tensegrity_core.sweep.computations import COMPUTATIONS, ResultSpec
from tensegrity_core.sweep.computations.results import Column, Options
from tensegrity_core.sweep.errors import SweepError
from tensegrity_core.sweep.keypath import KeyPathError, Location, format_location, resolve
from tensegrity_core.sweep.points import FIXED, RANDOM, Point, Quantity, build_points, count, grid_values

EXAMPLES_DIR = Path(__file__).parent / "examples"
_SHIPPED = ShippedFiles(EXAMPLES_DIR, "sweep", "shipped sweeps", SweepError)
TOP = ("name", "description", "base", "vary", "samples", "seed", "compute", "results")
#: Columns every row has besides the varied quantities and the results.
RESERVED = ("point", "seed", "status", "message", "run_time", "sweep_id")
#: A result every row has whatever the computation: it may be listed (the issue's list of
#: results names it) and adds no column.
ALWAYS_KEPT = "run_time"
MAX_FILE_BYTES = 1 << 20
MAX_POINTS = 1_000_000
MAX_VALUES = 100_000

#: A result as the sweep file lists it: ``(name, checked options, line)``.
ListedResult = tuple[str, Options, int | None]


# ------------------------------------------------------------------------------ the sweep
@dataclass(frozen=True)
class Sweep:
    """A checked sweep (immutable). ``points()`` lists its points; :func:`prepare` makes its
    :class:`Plan` (running the base once where a result needs it)."""

    name: str
    description: str
    base: Base
    computation: str
    options: Options
    quantities: tuple[Quantity, ...]
    samples: int
    seed: int
    results: tuple[ListedResult, ...]     # as read
    source: str | None = None
    folder: str = "."

    @property
    def n_points(self) -> int:
        return count(self.quantities, self.samples)

    @property
    def random(self) -> bool:
        """True when some quantity is a random sample (plots show histograms)."""
        return any(q.random for q in self.quantities)

    @property
    def sets_seed(self) -> bool:
        """Each point's seed goes into the scene's ``seed`` (sensor noise), unless varied."""
        return COMPUTATIONS[self.computation].uses_seed and not any(q.path == "seed" for q in self.quantities)

    def points(self) -> list[Point]:
        return build_points(self.quantities, self.samples, self.seed)

    @property
    def sweep_id(self) -> str:
        """A fingerprint of what a point's row depends on besides its inputs (the base, the
        computation, the results, the seed and which quantities are varied), so results of
        another sweep are not taken for this one's; the number of points is not part of it."""
        data = {"base": self.base.document, "compute": [self.computation, self.options],
                "vary": [[q.path, q.column, q.kind, q.scale] for q in self.quantities],
                "results": [[n, o] for n, o, _ in self.results], "seed": self.seed}
        text = json.dumps(data, sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class Plan:
    """Everything a worker needs besides the points: the base document, the computation,
    its options and the prepared results. Small and picklable; sent to each worker once."""

    document: dict[str, Any]
    computation: str
    options: Options
    quantities: tuple[Quantity, ...]
    results: tuple[ResultSpec, ...]
    sets_seed: bool

    @property
    def result_columns(self) -> list[Column]:
        return [c for r in self.results for c in r.columns]


def prepare(sweep: Sweep) -> Plan:
    """The sweep's :class:`Plan`: its results prepared (names and sizes of components from a
    short run of the base, references from a whole one, checked node names) and the
    computation's final options. Raises :class:`SweepError` when the base itself cannot be
    computed or a result's option does not fit it."""
    comp = COMPUTATIONS[sweep.computation]
    probes: dict[bool, Any] = {}

    def probe(full: bool = True) -> Any:
        if full not in probes:
            try:
                probes[full] = comp.probe(sweep.base.document, sweep.options, full=full)
            except Exception as err:  # noqa: BLE001 - the base itself cannot be computed; say why
                raise SweepError(f"the base {sweep.base.kind} {sweep.base.source!r} cannot be computed "
                                 f"(needed for the results' columns or reference): {err}",
                                 key=("base",), file=sweep.source and Path(sweep.source).name) from None
        return probes[full]

    specs = []
    for name, options, line in sweep.results:
        rdef = comp.results[name]
        data = None
        if rdef.prepare is not None:
            try:
                data = rdef.prepare(options, probe, sweep.folder)
            except OptionError as err:
                raise SweepError(str(err), key=("results", name), line=line,
                                 file=sweep.source and Path(sweep.source).name) from None
        specs.append(ResultSpec(name, options, tuple(rdef.columns(options, data)), data))
    seen = set(RESERVED) | {q.column for q in sweep.quantities}
    for spec in specs:
        for column, _ in spec.columns:
            if column in seen:
                raise SweepError(f"result column {column!r} appears twice (a varied quantity or another "
                                 f"result has that name; give one of them another with 'name' or "
                                 f"different options)", key=("results", spec.name),
                                 file=sweep.source and Path(sweep.source).name)
            seen.add(column)
    options = comp.finish_options(sweep.options, specs)
    return Plan(sweep.base.document, sweep.computation, options, sweep.quantities, tuple(specs), sweep.sets_seed)


# ------------------------------------------------------------------------------ loading
def sweep_names() -> list[str]:
    """Names of the shipped example sweeps."""
    return _SHIPPED.names()


def sweep_path(name: str) -> Path:
    """Path of the shipped sweep ``name``."""
    return _SHIPPED.path(name)


#: What :func:`load_sweep` reads: a sweep, a shipped sweep's name, a path, YAML text or a dict.
SweepSource = Sweep | str | Path | dict[str, Any]


def load_sweep(source: SweepSource) -> Sweep:
    """Read and check a sweep: a :class:`Sweep` (returned as is), a shipped sweep's name, a
    path to a YAML file, YAML text or a dict. Relative paths in it (the base, reference
    files) are resolved against the sweep file's folder (the current folder otherwise)."""
    if isinstance(source, Sweep):
        return source
    if isinstance(source, dict):
        return _Reader(None, Path.cwd()).sweep(source)
    if isinstance(source, str) and "\n" not in source and source in sweep_names() and not Path(source).is_file():
        source = sweep_path(source)
    if isinstance(source, Path) or (isinstance(source, str) and "\n" not in source and (
            source.lower().endswith((".yaml", ".yml")) or Path(source).is_file())):
        path = Path(source)
        try:
            if path.stat().st_size > MAX_FILE_BYTES:
                raise SweepError(f"sweep file {str(path)!r} is larger than {MAX_FILE_BYTES} bytes")
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise SweepError(f"sweep file not found: {str(path)!r}"
                             f"{suggest(path.stem, sweep_names(), ' (a shipped sweep: {!r}?)')}") from None
        except (OSError, UnicodeDecodeError) as err:
            raise SweepError(f"cannot read sweep file {str(path)!r}: {getattr(err, 'strerror', None) or err}") from None
        return _Reader(path.name, path.parent.resolve(), str(path)).sweep(_parse(text, path.name))
    if isinstance(source, str):
        if ":" not in source:
            raise SweepError(f"{source!r} is neither a shipped sweep{suggest(source, sweep_names())} "
                             f"({', '.join(sweep_names())}), an existing sweep file nor YAML text")
        if len(source) > MAX_FILE_BYTES:
            raise SweepError(f"sweep text is larger than {MAX_FILE_BYTES} bytes")
        return _Reader(None, Path.cwd()).sweep(_parse(source, None))
    raise SweepError(f"cannot load a sweep from a {type(source).__name__}; give a name, a path, YAML text or a dict")


def _parse(text: str, file: str | None) -> object:
    from tensegrity_core.schema import SchemaError, parse_text

    try:
        data = parse_text(text, "yaml")
    except SchemaError as err:
        raise SweepError(err.reason, line=err.line, file=file) from None
    return data


def _line(container: object, key: object) -> int | None:
    lines: dict[object, int] | None = getattr(container, "key_lines", None)
    if lines is not None and key in lines:
        return lines[key]
    items: list[int] | None = getattr(container, "item_lines", None)
    if items is not None and isinstance(key, int) and key < len(items):
        return items[key]
    line: int | None = getattr(container, "line", None)
    return line


class _Reader:
    """Walks the parsed sweep file, keeping key paths and lines for the error messages."""

    def __init__(self, file: str | None, folder: Path, source: str | None = None):
        self.file = file
        self.folder = folder
        self.source = source

    def error(self, message: str, path: KeyPath, container: object = None, key: object = None) -> SweepError:
        line = _line(container, key) if container is not None else None
        return SweepError(message, key=path, line=line, file=self.file)

    def mapping(self, value: object, path: KeyPath, parent: object = None, key: object = None) -> dict[Any, Any]:
        if not isinstance(value, dict):
            raise self.error(f"must be a mapping, got {type_name(value)} ({value!r})", path, parent, key)
        return value

    def keys(self, d: dict[Any, Any], path: KeyPath, allowed: tuple[str, ...],
             required: Iterable[str] = ()) -> None:
        for k in d:
            if k not in allowed:
                raise self.error(f"unknown key {k!r}{suggest(k, allowed)}; allowed: {', '.join(allowed)}",
                                 path + (k,), d, k)
        for k in required:
            if k not in d:
                raise self.error(f"missing required key {k!r}", path, d, None)

    def checked(self, d: dict[str, Any], key: str, path: KeyPath, check: Check) -> Any:
        """``check`` of ``d[key]`` (as plain data); its :class:`OptionError` is raised as the
        error at ``path + (key,)``."""
        try:
            return check(plain(d[key]))
        except OptionError as err:
            raise self.error(str(err), path + (key,), d, key) from None

    def number(self, d: dict[str, Any], key: str, path: KeyPath, *, lo: float | None = None,
               lo_open: bool = False) -> float:
        value: float = self.checked(d, key, path, number_check(lo=lo, lo_open=lo_open))
        return value

    def integer(self, d: dict[str, Any], key: str, path: KeyPath, *, lo: int = 0, hi: int | None = None) -> int:
        v = d[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
            bound = f">= {lo}" + (f" and <= {hi}" if hi is not None else "")
            raise self.error(f"must be an integer {bound}, got {v!r}", path + (key,), d, key)
        return int(v)

    def string(self, d: dict[str, Any], key: str, path: KeyPath) -> str:
        v = d[key]
        if not isinstance(v, str):
            raise self.error(f"must be a string, got {type_name(v)} ({v!r})", path + (key,), d, key)
        return v

    def named(self, item: object, path: KeyPath, holder: object, index: object,
              what: str) -> tuple[str, dict[str, Any], KeyPath]:
        """``name`` or ``{name: {options}}`` -> (name, options mapping, path of the options)."""
        if isinstance(item, str):
            return item, {}, path
        if isinstance(item, dict) and len(item) == 1:
            name = next(iter(item))
            options = item[name] if item[name] is not None else {}
            return name, self.mapping(options, path + (name,), item, name), path + (name,)
        raise self.error(f"each {what} is a name or a one-key mapping {{name: {{options}}}}, got {item!r}",
                         path, holder, index)

    # -- the sweep ---------------------------------------------------------------------------
    def sweep(self, data: object) -> Sweep:
        d = self.mapping(data, ())
        self.keys(d, (), TOP, required=("base", "vary", "compute", "results"))
        name = self.string(d, "name", ()) if "name" in d else (Path(self.file).stem if self.file else "sweep")
        description = self.string(d, "description", ()) if "description" in d else ""
        base = self.base(d["base"], ("base",), d)
        computation, options = self.compute(d["compute"], ("compute",), d, base)
        quantities = self.vary(d["vary"], ("vary",), d, base)
        seed = self.integer(d, "seed", (), hi=2**63 - 1) if "seed" in d else 0
        random = any(q.random for q in quantities)
        if random and "samples" not in d:
            raise self.error("random quantities need 'samples' (how many points to draw)", (), d, "vary")
        if not random and "samples" in d:
            raise self.error("'samples' counts random draws, but no quantity is random (uniform, normal, "
                             "log_uniform)", ("samples",), d, "samples")
        samples = self.integer(d, "samples", (), lo=1, hi=MAX_POINTS) if "samples" in d else 1
        n = count(quantities, samples)
        if n > MAX_POINTS:
            raise self.error(f"the sweep has {n} points; at most {MAX_POINTS}", ("vary",), d, "vary")
        results = self.results(d["results"], ("results",), d, computation)
        return Sweep(name=name, description=description, base=base, computation=computation, options=options,
                     quantities=tuple(quantities), samples=samples, seed=seed, results=tuple(results),
                     source=self.source, folder=str(self.folder))

    def base(self, value: object, path: KeyPath, parent: dict[str, Any]) -> Base:
        d = self.mapping(value, path, parent, "base")
        self.keys(d, path, BASE_KINDS)
        if len(d) != 1:
            raise self.error("give exactly one of 'scene' or 'structure'", path, parent, "base")
        kind = next(iter(d))
        try:
            return load_base(kind, d[kind], self.folder)
        except BaseError as err:
            raise self.error(str(err), path + (kind,), d, kind) from None

    def compute(self, value: object, path: KeyPath, parent: dict[str, Any], base: Base) -> tuple[str, Options]:
        name, options, opath = self.named(value, path, parent, "compute", "computation")
        if name not in COMPUTATIONS:
            raise self.error(f"unknown computation {name!r}{suggest(name, COMPUTATIONS)}; computations: "
                             f"{', '.join(COMPUTATIONS)}", path, parent, "compute")
        comp = COMPUTATIONS[name]
        if comp.base != base.kind:
            raise self.error(f"computation {name!r} needs a {comp.base} as its base (base: {{{comp.base}: ...}}), "
                             f"this sweep's base is a {base.kind}", path, parent, "compute")
        if comp.model is not None and base.model_kind != comp.model:
            raise self.error(f"computation {name!r} needs a {comp.model} scene, {base.source!r} is "
                             f"{base.model_kind!r}", path, parent, "compute")
        return name, self.options(options, opath, comp.options, comp.required_options)

    def options(self, options: dict[str, Any], path: KeyPath, checks: dict[str, Check],
                required: Iterable[str]) -> Options:
        self.keys(options, path, tuple(checks), required=required)
        out: Options = {}
        for k in options:
            out[k] = self.checked(options, k, path, checks[k])
        return out

    def vary(self, value: object, path: KeyPath, parent: dict[str, Any], base: Base) -> list[Quantity]:
        d = self.mapping(value, path, parent, "vary")
        if not d:
            raise self.error("list at least one quantity to vary", path, parent, "vary")
        out: list[Quantity] = []
        taken: dict[Location, str] = {}
        for key_path, spec in d.items():
            qpath = path + (key_path,)
            if not isinstance(key_path, str):
                raise self.error(f"a key path must be a string, got {key_path!r}", qpath, d, key_path)
            q = self.quantity(key_path, spec, qpath, d, base)
            for loc in q.locations:
                if loc in taken:
                    raise self.error(f"{format_location(loc)} is already varied by {taken[loc]!r}", qpath, d, key_path)
                taken[loc] = key_path
            if q.column in RESERVED or any(q.column == o.column for o in out):
                raise self.error(f"column name {q.column!r} is taken; give this quantity another with 'name'",
                                 qpath, d, key_path)
            out.append(q)
        return out

    def quantity(self, key_path: str, spec: object, path: KeyPath, parent: dict[str, Any],
                 base: Base) -> Quantity:
        if not isinstance(spec, dict):     # a bare list of values or a single value
            spec_values = spec if isinstance(spec, list) else [spec]
            spec = {"values": spec_values}
            holder = parent
        else:
            holder = spec
        allowed = FIXED + RANDOM + ("scale", "name")
        self.keys(spec, path, allowed)
        kinds = [k for k in spec if k in FIXED + RANDOM]
        if len(kinds) != 1:
            raise self.error(f"give exactly one of {', '.join(FIXED + RANDOM)}", path, parent, key_path)
        kind = kinds[0]
        scale = False
        if "scale" in spec:
            if not isinstance(spec["scale"], bool):
                raise self.error(f"must be true or false, got {spec['scale']!r}", path + ("scale",), spec, "scale")
            scale = spec["scale"]
        column = self.string(spec, "name", path) if "name" in spec else key_path
        values: tuple[Any, ...] = ()
        params: tuple[float, ...] = ()
        kpath = path + (kind,)
        if kind == "values":
            v = spec["values"]
            if not isinstance(v, list) or not v:
                raise self.error(f"must be a non-empty list, got {type_name(v)} ({v!r})", kpath, holder, "values")
            if len(v) > MAX_VALUES:
                raise self.error(f"at most {MAX_VALUES} values, got {len(v)}", kpath, holder, "values")
            for i, x in enumerate(v):
                ok = isinstance(x, (str, bool)) or (isinstance(x, (int, float)) and math.isfinite(x))
                if not ok or (scale and isinstance(x, (str, bool))):
                    want = "finite numbers (factors)" if scale else "numbers, strings or booleans"
                    raise self.error(f"values must be {want}, got {x!r}", kpath + (i,), v, i)
            values = tuple(v)
        elif kind == "grid":
            g = self.mapping(spec["grid"], kpath, spec, "grid")
            self.keys(g, kpath, ("from", "to", "num", "spacing"), required=("from", "to", "num"))
            lo, hi = self.number(g, "from", kpath), self.number(g, "to", kpath)
            num = self.integer(g, "num", kpath, lo=1, hi=MAX_VALUES)
            spacing = self.string(g, "spacing", kpath) if "spacing" in g else "linear"
            if spacing not in ("linear", "log"):
                raise self.error(f"must be linear or log, got {spacing!r}{suggest(spacing, ('linear', 'log'))}",
                                 kpath + ("spacing",), g, "spacing")
            if spacing == "log" and (lo <= 0 or hi <= 0):
                raise self.error(f"a log grid needs from, to > 0, got {lo:g}, {hi:g}", kpath, spec, "grid")
            values = grid_values(lo, hi, num, spacing)
        else:
            g = self.mapping(spec[kind], kpath, spec, kind)
            names = ("mean", "std") if kind == "normal" else ("low", "high")
            self.keys(g, kpath, names, required=names)
            a, b = self.number(g, names[0], kpath), self.number(g, names[1], kpath, lo=0.0)
            if kind != "normal" and not a < b:
                raise self.error(f"needs low < high, got {a:g}, {b:g}", kpath, spec, kind)
            if kind == "log_uniform" and a <= 0:
                raise self.error(f"needs low > 0, got {a:g}", kpath + ("low",), g, "low")
            params = (a, b)
        try:
            locations = tuple(resolve(base.document, key_path, need_number=scale))
        except KeyPathError as err:
            raise self.error(f"{err} (in the base {base.kind} {base.source!r})", path, parent, key_path) from None
        log = kind == "log_uniform" or (kind == "grid" and spacing == "log")
        return Quantity(key_path, column, kind, values, params, scale, locations, log)

    def results(self, value: object, path: KeyPath, parent: dict[str, Any], computation: str) -> list[ListedResult]:
        if not isinstance(value, list) or not value:
            raise self.error(f"must be a non-empty list of results, got {type_name(value)} ({value!r})",
                             path, parent, "results")
        comp = COMPUTATIONS[computation]
        out: list[ListedResult] = []
        seen: set[tuple[str, str]] = set()
        for i, item in enumerate(value):
            name, options, opath = self.named(item, path + (i,), value, i, "result")
            if name == ALWAYS_KEPT:
                if options:
                    raise self.error(f"{ALWAYS_KEPT} takes no options (it is the point's wall time on its "
                                     f"worker, in every row)", path + (i,), value, i)
                continue
            if name not in comp.results:
                raise self.error(f"unknown result {name!r} of {computation!r}"
                                 f"{suggest(name, [*comp.results, ALWAYS_KEPT])}; results: {', '.join(comp.results)} "
                                 f"(and {ALWAYS_KEPT}, in every row)", path + (i,), value, i)
            rdef = comp.results[name]
            checked = self.options(options, opath, rdef.options, comp.required.get(name, ()))
            key = (name, json.dumps(checked, sort_keys=True, default=repr))
            if key in seen:
                raise self.error(f"result {name!r} is listed twice with the same options", path + (i,), value, i)
            seen.add(key)
            out.append((name, checked, _line(value, i)))
        return out
