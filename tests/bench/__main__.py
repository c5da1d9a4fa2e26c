"""``python -m tests.bench [--full] [--only GROUP[:FUNCTION]] [--json FILE] [--plot-dir DIR] [--data-dir DIR]``

Runs every benchmark (``tests/bench/bench_*.py``), prints one table, and compares each row
with its baseline measured in the same run (ratios: these machines are shared and noisy).
Quick mode (default) is the CI smoke run, seconds per group, and writes files only where
asked, never into ``docs/`` (its rough figures are not the docs'); ``--full`` is the docs run
and by default writes the table as ``docs/bench/results.json``, the raw data behind the plots
into ``docs/bench/`` and the plots into ``docs/img/performance/`` (tracked files: see
``docs/design/performance.md``), and says where before it runs; rows of groups not run keep
their earlier values in that JSON file.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import importlib
import json
import os
import pkgutil
import random
import sys
import time
from dataclasses import asdict
from pathlib import Path

from tensegrity_core.sim.general.kernels.jit import KERNELS_VARIABLE
from tensegrity_ros.rclpy_utils.env import ensure_ros_environment
from tests.bench import harness


def main(argv=None) -> int:
    ensure_ros_environment()   # the suite's DDS set-up (loopback only) for in-process nodes too
    # every node a benchmark starts, in its children and in this process, talks in one
    # domain: the caller's (the test suite gives each module its own, so a benchmark run
    # inside the suite never answers another module's clients), else one of its own
    os.environ.setdefault("ROS_DOMAIN_ID", str(200 + random.randrange(30)))
    ap = argparse.ArgumentParser(prog="python -m tests.bench")
    ap.add_argument("--full", action="store_true",
                    help="full mode (docs figures: writes docs/bench/ and docs/img/performance/ unless told "
                         "elsewhere); default quick")
    ap.add_argument("--only", action="append", default=[], help="run only these groups (or GROUP:FUNCTION)")
    ap.add_argument("--json", default=None, help="write the rows as JSON to this file")
    ap.add_argument("--plot-dir", default=None, help="write plots (PNG) into this folder")
    ap.add_argument("--data-dir", default=None, help="write the data behind the plots (JSON) here")
    args = ap.parse_args(argv)
    docs = Path(__file__).resolve().parents[2] / "docs"
    if not args.full:
        outputs = (args.json, args.plot_dir, args.data_dir)
        into_docs = [p for p in outputs if p and Path(p).resolve().is_relative_to(docs)]
        if into_docs:
            ap.error(f"quick mode's rough figures would be written over the docs' ({', '.join(into_docs)}): "
                     "give --full, or a place outside docs/")
    if args.full:
        if os.environ.get(KERNELS_VARIABLE) and not (args.json and args.plot_dir and args.data_dir):
            # the docs' table and figures are the default kernels' (several benchmarks time
            # both kinds themselves): rows of another choice would replace them under their names
            ap.error(f"{KERNELS_VARIABLE}={os.environ[KERNELS_VARIABLE]} with --full writes over the docs' figures of "
                     "the default kernels: unset it, or give --json, --plot-dir and --data-dir elsewhere")
        args.json = args.json or str(docs / "bench" / "results.json")
        args.plot_dir = args.plot_dir or str(docs / "img" / "performance")
        args.data_dir = args.data_dir or str(docs / "bench")

    load_benchmarks()
    groups = {group for group, _ in harness.REGISTRY}
    names = {f"{group}:{fn.__name__}" for group, fn in harness.REGISTRY}
    unknown = sorted(set(args.only) - groups - names)
    if unknown:
        ap.error(f"unknown group(s) {', '.join(unknown)}; the groups are {', '.join(sorted(groups))} "
                 "(GROUP:FUNCTION picks one benchmark)")
    if args.full:
        print(_destinations(args), file=sys.stderr, flush=True)
    ctx = harness.Context(quick=not args.full, plot_dir=args.plot_dir, data_dir=args.data_dir)
    harness.use_timing(harness.QUICK_TIMING if ctx.quick else harness.FULL_TIMING)
    rows: list[harness.Row] = []
    ran = set()
    # what the benchmarks shared (Context.kept) ends with the run
    with contextlib.closing(ctx), _heap_frozen():
        for group, fn in harness.REGISTRY:
            if args.only and group not in args.only and f"{group}:{fn.__name__}" not in args.only:
                continue
            print(f"== {group}: {fn.__name__}", file=sys.stderr, flush=True)
            gc.collect()                 # the last benchmark's garbage is not the next one's cost
            started = time.perf_counter()
            new_rows = fn(ctx)
            print(f"   {group}: {fn.__name__} took {time.perf_counter() - started:.1f} s", file=sys.stderr,
                  flush=True)
            for r in new_rows:
                r.bench = fn.__name__
            rows.extend(new_rows)
            ran.add((group, fn.__name__))
    by_name = {(r.group, r.name): r for r in rows}
    for r in rows:
        if r.baseline and (r.group, r.baseline) in by_name:
            r.ratio = harness.ratio_to_baseline(r, by_name[(r.group, r.baseline)])
        if r.met is None:
            r.met = harness.target_met(r)
    w = max([len(r.name) for r in rows] + [10])
    print(f"{'group':10} {'benchmark':{w}} {'value':>12} {'unit':8} {'vs baseline':>22}  {'target':7} target / note")
    for r in rows:
        ratio = harness.format_ratio(r) if r.ratio is not None else ""
        print(f"{r.group:10} {r.name:{w}} {r.value:12.4g} {r.unit:8} {ratio:>22}  {VERDICT[r.met]:7} "
              f"{r.target} {r.note}".rstrip())
    _summarise_targets(rows)
    if args.json:
        whole = {g for g in groups if all((g, fn.__name__) in ran for gg, fn in harness.REGISTRY if gg == g)}
        _write_rows(Path(args.json), rows, ran, whole)
    return 0


@contextlib.contextmanager
def _heap_frozen():
    """What the process holds when the run starts (the interpreter's, its imports', a test
    session's objects) kept out of the collector's scans for the run (``gc.freeze``): the
    ``gc.collect()`` before each benchmark then goes through what the run made, its garbage
    included, instead of the whole heap again (~0.1 s of CPU each in a process holding
    200,000 objects); given back to the collector when the run ends."""
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _destinations(args: argparse.Namespace) -> str:
    """The line that says where a full run writes (by default tracked files under docs/)."""
    return (f"full mode writes the table to {args.json}, the data behind the plots into {args.data_dir}/ "
            f"and the plots into {args.plot_dir}/")


def load_benchmarks() -> None:
    """Import every ``tests/bench/bench_*.py``: their benchmarks register themselves."""
    for m in sorted(pkgutil.iter_modules([str(Path(__file__).parent)])):
        if m.name.startswith("bench_"):
            importlib.import_module(f"tests.bench.{m.name}")


#: The verdict column: a target met, missed, or not checked (in words, or nothing to compare).
VERDICT = {True: "met", False: "MISSED", None: ""}


def _summarise_targets(rows) -> None:
    """One line of counts of the targets checked, then every missed one with its value."""
    checked = [r for r in rows if r.met is not None]
    missed = [r for r in checked if not r.met]
    unchecked = sum(1 for r in rows if r.target and r.met is None)
    print(f"\ntargets: {len(checked) - len(missed)} met, {len(missed)} missed of {len(checked)} checked"
          + (f" ({unchecked} in words, not checked)" if unchecked else ""))
    for r in missed:
        of = "of" if harness.is_rate(r.unit) else "against"
        ratio = f" ({r.ratio:.3g}x {of} {r.baseline!r})" if r.ratio is not None else ""
        print(f"  MISSED  {r.group}: {r.name}: {r.value:.4g} {r.unit}{ratio}; target {r.target}")


def _write_rows(path: Path, rows, ran: set, whole_groups: set) -> None:
    """Write the rows as JSON; rows of benchmarks not run this time are kept from the file,
    so ``--full --only GROUP[:FUNCTION]`` refreshes part of the docs' table (an older row
    that does not name its benchmark goes when its whole group ran or a new row has its
    name)."""
    kept = []
    new_names = {(r.group, r.name) for r in rows}
    if path.exists():
        try:
            kept = [r for r in json.loads(path.read_text())
                    if (r.get("group"), r.get("bench")) not in ran
                    and not (not r.get("bench") and (r.get("group") in whole_groups
                                                     or (r.get("group"), r.get("name")) in new_names))]
        except (ValueError, AttributeError):
            kept = []
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(kept + [asdict(r) for r in rows], indent=2, default=str))


if __name__ == "__main__":
    sys.exit(main())
