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
the base, computations that do not fit the base, unknown results and options, and a key path
whose last key is new in the base when the computation's loader takes that key at none of
the quantity's values (a misspelt parameter). Otherwise what a point's values do to the base
is not checked here: each point's document goes through the core's loader on a worker, and a
bad value becomes that point's row with the loader's message.

The checks are the shared ones of :class:`tensegrity_core.schema.Reader` (and the options'
checks of :mod:`~tensegrity_core.sweep.checks`, applied through it); this module holds only
the sweep's schema.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, cast

from tensegrity_core.errors import TensegrityError, interrupted
from tensegrity_core.schema import (
    KeyPath,
    KeyPathError,
    Limits,
    Reader,
    SchemaError,
    ShippedFiles,
    excerpt,
    exists,
    format_key_path,
    get_at,
    line_of,
    parse_text,
    plain,
    read_file,
    resolve,
    resolve_source,
    suggest,
)
from tensegrity_core.sweep.base import BASE_KINDS, Base, load_base
from tensegrity_core.sweep.checks import Check, OptionError
from tensegrity_core.sweep.computations import COMPUTATIONS, ResultSpec
from tensegrity_core.sweep.computations.results import Column, Options
from tensegrity_core.sweep.errors import SweepError
from tensegrity_core.sweep.points import FIXED, RANDOM, Point, Quantity, apply, build_points, count, grid_values

EXAMPLES_DIR = Path(__file__).parent / "examples"
#: The shipped sweeps, by name.
SHIPPED_SWEEPS: Final = ShippedFiles(EXAMPLES_DIR, "sweep", "shipped sweeps", SweepError)
TOP = ("name", "description", "base", "vary", "samples", "seed", "compute", "results")
#: Columns every row has besides the varied quantities and the results.
RESERVED = ("point", "seed", "status", "message", "run_time", "sweep_id")
#: A result every row has whatever the computation: it may be listed (the issue's list of
#: results names it) and adds no column.
ALWAYS_KEPT = "run_time"
#: Bounds of a sweep file (at most 1 MiB; nesting and aliases as every description).
LIMITS: Final = Limits(max_bytes=1 << 20)
MAX_POINTS = 1_000_000
MAX_VALUES = 100_000
#: The unit a refused bound of a swept value is stated in: the swept key's own (a sweep
#: names keys of any file, and keeps the numbers in their units).
SWEPT_UNIT: Final = "(the swept key's unit)"

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

    @property
    def result_units(self) -> dict[str, str]:
        """The unit of each result column (:attr:`~tensegrity_core.sweep.computations.results.ResultDef.unit`)."""
        return {name: unit for r in self.results for (name, _), unit in zip(r.columns, r.units)}


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
                if interrupted(err):
                    raise KeyboardInterrupt from err
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
                raise SweepError(err.reason, key=("results", name), line=line,
                                 file=sweep.source and Path(sweep.source).name) from None
        columns = rdef.columns(options, data)
        specs.append(ResultSpec(name, options, tuple(columns), data, rdef.units(options, data, columns)))
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
    return SHIPPED_SWEEPS.names()


def sweep_path(name: str) -> Path:
    """Path of the shipped sweep ``name``."""
    return SHIPPED_SWEEPS.path(name)


#: What :func:`load_sweep` reads: a sweep, a shipped sweep's name, a path, YAML text or a dict.
SweepSource = Sweep | str | Path | dict[str, Any]


def load_sweep(source: SweepSource) -> Sweep:
    """Read and check a sweep: a :class:`Sweep` (returned as is), a path to an existing file
    or a shipped sweep's name, YAML text or a dict (the rules of
    :func:`~tensegrity_core.schema.resolve_source`). Relative paths in it (the base,
    reference files) are resolved against the sweep file's folder (the current folder
    otherwise)."""
    if isinstance(source, Sweep):
        return source
    found = resolve_source(source, what="sweep", shipped=SHIPPED_SWEEPS, error=SweepError)
    if found.kind == "data":
        return _SweepReader(None, Path.cwd()).sweep(found.data)
    if found.kind == "text":
        return _SweepReader(None, Path.cwd()).sweep(parse_text(found.text, "yaml", limits=LIMITS, error=SweepError))
    path = cast(Path, found.path)
    data, _, _ = read_file(path, limits=LIMITS, error=SweepError, fmt="yaml", what="sweep file")
    return _SweepReader(path.name, path.parent.resolve(), str(path)).sweep(data)


def _on_plain(check: Check) -> Check:
    """``check`` applied to the value as plain data (options are kept in the sweep and sent
    to workers, without the lines of the parsed file)."""
    return lambda value: check(plain(value))


class _SweepReader(Reader):
    """The sweep file's schema over the shared checks; ``folder`` is where relative paths start."""

    def __init__(self, file: str | None, folder: Path, source: str | None = None):
        super().__init__(SweepError, file)
        self.folder = folder
        self.source = source

    def named(self, item: object, path: KeyPath, holder: object, index: object,
              what: str) -> tuple[str, dict[str, Any], KeyPath]:
        """``name`` or ``{name: {options}}`` -> (name, options mapping, path of the options)."""
        if isinstance(item, str):
            return item, {}, path
        if isinstance(item, dict) and len(item) == 1:
            name = next(iter(item))
            options = item[name] if item[name] is not None else {}
            return name, self.mapping(options, path + (name,), item, name), path + (name,)
        raise self.error(f"each {what} is a name or a one-key mapping {{name: {{options}}}}, got {excerpt(item)}",
                         path, holder, index)

    # -- the sweep ---------------------------------------------------------------------------
    def sweep(self, data: object) -> Sweep:
        d = self.mapping(data, ())
        self.keys(d, (), TOP, required=("base", "vary", "compute", "results"))
        name = self.string(d, "name", (), default=Path(self.file).stem if self.file else "sweep")
        description = self.string(d, "description", (), default="")
        base = self.base(d["base"], ("base",), d)
        computation, options = self.compute(d["compute"], ("compute",), d, base)
        quantities = self.vary(d["vary"], ("vary",), d, base, computation)
        seed = self.integer(d, "seed", (), default=0, lo=0, hi=2**63 - 1)
        random = any(q.random for q in quantities)
        if random and "samples" not in d:
            raise self.error("random quantities need 'samples' (how many points to draw)", (), d, "vary")
        if not random and "samples" in d:
            raise self.error("'samples' counts random draws, but no quantity is random (uniform, normal, "
                             "log_uniform)", ("samples",), d, "samples")
        samples = self.integer(d, "samples", (), default=1, lo=1, hi=MAX_POINTS)
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
        except SchemaError as err:              # not found (SweepError), or the file's own error
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
            out[k] = self.checked(options, k, path, _on_plain(checks[k]))
        return out

    def vary(self, value: object, path: KeyPath, parent: dict[str, Any], base: Base,
             computation: str) -> list[Quantity]:
        d = self.mapping(value, path, parent, "vary")
        if not d:
            raise self.error("list at least one quantity to vary", path, parent, "vary")
        out: list[Quantity] = []
        taken: dict[KeyPath, str] = {}
        for key_path, spec in d.items():
            qpath = path + (key_path,)
            if not isinstance(key_path, str):
                raise self.error(f"a key path must be a string, got {excerpt(key_path)}", qpath, d, key_path)
            q = self.quantity(key_path, spec, qpath, d, base)
            self.some_value_fits(q, qpath, d, base, computation)
            for loc in q.locations:
                if loc in taken:
                    raise self.error(f"{format_key_path(loc)} is already varied by {taken[loc]!r}", qpath, d, key_path)
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
        scale = self.boolean(spec, "scale", path, default=False)
        column = self.string(spec, "name", path, default=key_path)
        values: tuple[Any, ...] = ()
        params: tuple[float, ...] = ()
        kpath = path + (kind,)
        if kind == "values":
            v = self.sequence(spec["values"], kpath, holder, "values", nonempty=True)
            if len(v) > MAX_VALUES:
                raise self.error(f"at most {MAX_VALUES} values, got {len(v)}", kpath, holder, "values")
            for i, x in enumerate(v):
                ok = isinstance(x, (str, bool)) or (isinstance(x, (int, float)) and math.isfinite(x))
                if not ok or (scale and isinstance(x, (str, bool))):
                    want = "finite numbers (factors)" if scale else "numbers, strings or booleans"
                    raise self.error(f"values must be {want}, got {excerpt(x)}", kpath + (i,), v, i)
            values = tuple(v)
        elif kind == "grid":
            g = self.mapping(spec["grid"], kpath, spec, "grid")
            self.keys(g, kpath, ("from", "to", "num", "spacing"), required=("from", "to", "num"))
            lo, hi = self.number(g, "from", kpath, unit=SWEPT_UNIT), self.number(g, "to", kpath, unit=SWEPT_UNIT)
            num = self.integer(g, "num", kpath, lo=1, hi=MAX_VALUES)
            spacing = self.string(g, "spacing", kpath, default="linear", choices=("linear", "log"))
            if spacing == "log" and (lo <= 0 or hi <= 0):
                raise self.error(f"a log grid needs from, to > 0, got {lo:g}, {hi:g}", kpath, spec, "grid")
            values = grid_values(lo, hi, num, spacing)
        else:
            g = self.mapping(spec[kind], kpath, spec, kind)
            names = ("mean", "std") if kind == "normal" else ("low", "high")
            self.keys(g, kpath, names, required=names)
            a, b = self.number(g, names[0], kpath, unit=SWEPT_UNIT), self.number(g, names[1], kpath, unit=SWEPT_UNIT, lo=0.0)
            if kind != "normal" and not a < b:
                raise self.error(f"needs low < high, got {a:g}, {b:g}", kpath, spec, kind)
            if kind == "log_uniform" and a <= 0:
                raise self.error(f"needs low > 0, got {a:g}", kpath + ("low",), g, "low")
            params = (a, b)
        try:
            locations = tuple(resolve(base.document, key_path, need_number=scale))
        except KeyPathError as err:
            raise self.error(f"{err.reason} (in the base {base.kind} {base.source!r})", path, parent, key_path) from None
        log = kind == "log_uniform" or (kind == "grid" and spacing == "log")
        return Quantity(key_path, column, kind, values, params, scale, locations, log)

    def some_value_fits(self, q: Quantity, path: KeyPath, parent: dict[str, Any], base: Base,
                        computation: str) -> None:
        """Refuse a quantity none of whose values can be valid, which would otherwise make
        every point a failed row: one whose last key is new in the base (a key the base leaves
        at its default), or one whose values at an existing key are all of another kind
        (number, text, boolean) than the base's value there, when the computation's loader
        takes the base with that key at none of the probed values. The probes: the first,
        middle and last values and every distinct text or boolean one (a key may take a
        number or a word such as ``auto``), or a random quantity's two parameters."""
        new = not all(exists(base.document, loc) for loc in q.locations)
        if not new:
            kinds = {_kind(get_at(base.document, loc)) for loc in q.locations}
            if not q.values or any(_kind(v) in kinds for v in q.values):
                return                      # numbers at a number (grids and random ones are numbers)
        probes = [q.values[0], q.values[len(q.values) // 2], q.values[-1]] if q.values else list(q.params)
        probes += [v for v in q.values if isinstance(v, (str, bool))]
        load = COMPUTATIONS[computation].load
        first: TensegrityError | None = None
        for value in dict.fromkeys((type(v), v) for v in probes):
            try:
                load(apply(base.document, (q,), (value[1],)))
                return
            except TensegrityError as err:
                first = first or err
        where = format_key_path(q.locations[0])
        if new:
            raise self.error(f"the base {base.kind} {base.source!r} has no {where!r} and takes none of its values "
                             f"there: {first}", path, parent, q.path)
        raise self.error(f"the base {base.kind} {base.source!r} takes none of these values at {where!r}: {first}",
                         path, parent, q.path)

    def results(self, value: object, path: KeyPath, parent: dict[str, Any], computation: str) -> list[ListedResult]:
        value = self.sequence(value, path, parent, "results", of="results", nonempty=True)
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
            out.append((name, checked, line_of(value, i)))
        return out


def _kind(value: object) -> str:
    """A value's kind as a loader tells them apart: boolean, number (int or float), text, or
    its type's name."""
    if isinstance(value, bool):
        return "boolean"
    return "number" if isinstance(value, (int, float)) else type(value).__name__
