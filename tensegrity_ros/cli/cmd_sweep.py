"""``tensegrity sweep FILE`` and ``tensegrity sweeps``: parameter sweeps on Dask distributed.

FILE is a sweep file (YAML, see docs/sweeps.md) or the name of a shipped sweep. The points
run on an embedded local Dask cluster (``--workers N``, default the number of cores) or on
an existing one (``--scheduler ADDRESS``); a progress bar on stderr shows the points done,
failed and the time left. ``-o OUT.parquet`` (or ``.csv``) writes one row per point; while
it runs the finished rows are in ``OUT.parquet.partial.jsonl``, and ``--resume`` runs only
the points not there yet. ``--plot OUT.png`` draws the results against the varied
quantities (``--plot`` alone: beside the output, ``OUT.png``). Exit codes: 0 when the sweep ran (failed points are rows of the table), 2 for a
bad sweep file or option, 1 when the sweep cannot run (e.g. the scheduler cannot be
reached; nothing is written then), 130 when interrupted (finished rows kept).
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections import Counter
from pathlib import Path

from tensegrity_ros.cli._common import CliError, Row, Subparsers, add_json_flag, add_listing, print_json

ORDER = 55


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "sweep", help="run a parameter sweep or Monte Carlo ensemble on Dask (one row per point)",
        description="Vary quantities of a scene or structure (grids, lists, random samples), compute at "
                    "every point on a Dask cluster (embedded by default), keep scalar results.")
    p.add_argument("file", help="sweep file (.yaml) or the name of a shipped sweep (tensegrity sweeps)")
    p.add_argument("-o", "--output", default=None, help="write the table to OUT.parquet or OUT.csv")
    p.add_argument("--resume", action="store_true",
                   help="keep the rows already in the output (and its journal) and run only the others")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes of the embedded cluster (default: the number of cores; 0: no "
                        "cluster, one point after another in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on an existing Dask cluster (e.g. tcp://127.0.0.1:8786) instead")
    p.add_argument("--connect-timeout", type=float, default=10.0, metavar="S",
                   help="seconds to wait for the scheduler and its first worker (default 10)")
    p.add_argument("--batch", type=int, default=None, metavar="N",
                   help="points per task (default: adaptive, each worker's share of the rest, at most ~0.5 s of work)")
    p.add_argument("--plot", nargs="?", const="", default=None, metavar="PNG",
                   help="draw the results against the varied quantities (default file: the output's name "
                        "with .png, or SWEEP_NAME.png here without -o)")
    p.add_argument("--plot-result", action="append", default=None, metavar="COLUMN",
                   help="a result column (or run_time) to plot (repeatable; default: the numeric results, up to 6)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_json_flag(p)
    p.set_defaults(func=run_sweep_command)

    add_listing(subparsers, "sweeps", help="list the shipped example sweeps",
                description="The sweeps shipped with tensegrity_core.sweep, with their descriptions.",
                rows=_sweep_rows, details=_sweep_details)


def _sweep_rows() -> list[Row]:
    from tensegrity_core.sweep import load_sweep, sweep_names, sweep_path

    rows = []
    for name in sweep_names():
        s = load_sweep(sweep_path(name))
        rows.append({"name": name, "description": s.description, "base": f"{s.base.kind} {s.base.source}",
                     "compute": s.computation, "points": s.n_points,
                     "vary": [q.column for q in s.quantities], "file": str(sweep_path(name))})
    return rows


def _sweep_details(r: Row) -> str:
    return f"{r['base']}, {r['compute']}, {r['points']} points; varies {', '.join(r['vary'])}"


def run_sweep_command(args: argparse.Namespace) -> int:
    from tensegrity_core.sweep import SweepError, load_sweep
    from tensegrity_core.sweep.engine import run_sweep
    from tensegrity_core.sweep.spec import prepare
    from tensegrity_core.sweep.store import check_output_path
    from tensegrity_core.sweep.task import RowStatus

    if args.plot is not None and args.plot and not args.plot.lower().endswith(".png"):
        raise CliError(f"--plot must end in .png, got {args.plot!r}")
    if args.workers is not None and args.workers < 0:
        raise CliError(f"--workers must be >= 0, got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise CliError("--workers sizes the embedded cluster; with --scheduler the cluster has its own workers")
    if args.batch is not None and args.batch < 1:
        raise CliError(f"--batch must be >= 1, got {args.batch}")
    if not args.connect_timeout > 0:
        raise CliError(f"--connect-timeout must be > 0 s, got {args.connect_timeout:g}")
    if args.resume and args.output is None:
        raise CliError("--resume needs the output (-o) to resume from")
    try:
        sweep = load_sweep(args.file)
        if args.output is not None:
            check_output_path(Path(args.output))
        if args.plot == "":
            args.plot = str(default_plot_path(sweep.name, args.output))
        plan = prepare(sweep)
        if args.plot:
            from tensegrity_core.sweep.plotting import plotted_columns

            plotted_columns(plan, args.plot_result)
    except SweepError as err:
        raise CliError(str(err)) from None
    except KeyboardInterrupt:              # while the base is computed for the results' columns
        return _interrupted(args.output)
    t0 = time.perf_counter()
    try:
        table = run_sweep(sweep, output=args.output, resume=args.resume, workers=args.workers,
                          scheduler=args.scheduler, connect_timeout=args.connect_timeout, batch=args.batch,
                          progress=not (args.quiet or args.json), plan=plan)
    except SweepError as err:
        raise CliError(str(err), code=1) from None
    except KeyboardInterrupt:
        return _interrupted(args.output)
    wall = time.perf_counter() - t0
    if args.plot:
        from tensegrity_core.sweep.plotting import plot_sweep

        try:
            plot_sweep(table, sweep, args.plot, args.plot_result, plan=plan)
        except SweepError as err:
            raise CliError(str(err), code=1) from None
    statuses = Counter(table["status"])
    reasons: Counter[tuple[str, str]] = Counter()
    example: dict[tuple[str, str], str] = {}
    for status, message in zip(table["status"], table["message"]):
        if status != RowStatus.OK:         # group messages that differ only in their numbers
            key = (status, re.sub(r"[-+]?\d[\d.]*(?:e[-+]?\d+)?", "#", str(message)))
            reasons[key] += 1
            example.setdefault(key, str(message))
    summary = {"sweep": sweep.name, "points": len(table), "status": dict(statuses),
               "ran": table.attrs.get("ran"), "kept": table.attrs.get("kept"),
               "wall_time": wall, "engine": _engine(args), "output": args.output, "plot": args.plot,
               "failures": [{"status": k[0], "message": example[k], "points": n} for k, n in reasons.most_common(5)]}
    if args.json:
        print_json(summary)
        return 0
    counts = ", ".join(f"{n} {s}" for s, n in sorted(statuses.items()))
    ran = table.attrs.get("ran", len(table))
    where = f"{ran} run in {wall:.1f} s {'in' if args.workers == 0 and not args.scheduler else 'on'} " \
            f"{summary['engine']}" if ran else "all kept from the earlier run"
    kept = table.attrs.get("kept", 0)
    print(f"{sweep.name}: {len(table)} points ({counts}); {where}" + (f", {kept} kept" if ran and kept else ""))
    for f in summary["failures"]:
        print(f"  {f['points']} {f['status']}, e.g.: {f['message'][:160]}")
    for written, label in (("output", "results"), ("plot", "plot")):
        if summary[written]:
            print(f"{label} written to {summary[written]}")
    return 0


def _interrupted(output: str | None) -> int:
    """Say what an interrupted sweep kept (the journal's points, or nothing); 130."""
    from tensegrity_core.sweep.store import journal_path

    journal = journal_path(Path(output)) if output is not None else None
    if journal is not None and journal.exists():
        kept = max(0, len(journal.read_text(encoding="utf-8", errors="replace").splitlines()) - 1)
        print(f"interrupted: {kept} finished point{'s' if kept != 1 else ''} kept in {journal}; "
              f"--resume runs the others", file=sys.stderr)
    elif journal is not None:
        print("interrupted before the first point finished: nothing written", file=sys.stderr)
    else:
        print("interrupted (without -o nothing is kept)", file=sys.stderr)
    return 130


def default_plot_path(sweep_name: str, output: str | None) -> Path:
    """Where ``--plot`` without a file draws: beside the output (``fold.parquet`` ->
    ``fold.png``), or ``SWEEP_NAME.png`` in the current directory without ``-o``. The name
    is the sweep file's free text: only its letters, digits, ``.``, ``_`` and ``-`` (others
    become ``_``, at most 100) make the file name, so it never leaves the directory."""
    if output is not None:
        return Path(output).with_suffix(".png")
    stem = re.sub(r"[^A-Za-z0-9._-]", "_", sweep_name)[:100].lstrip(".")
    return Path(f"{stem or 'sweep'}.png")


def _engine(args: argparse.Namespace) -> str:
    if args.scheduler:
        return f"the Dask cluster at {args.scheduler}"
    if args.workers == 0:
        return "this process, one point after another (no cluster)"
    from tensegrity_core.sweep.engine import default_workers

    n = args.workers if args.workers is not None else default_workers()
    return f"an embedded Dask cluster of {n} worker process{'es' if n != 1 else ''}"
