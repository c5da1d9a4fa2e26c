"""``python -m tests.bench [--full] [--only GROUP] [--json FILE] [--plot-dir DIR]``"""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import sys
from dataclasses import asdict
from pathlib import Path

from tests.bench import harness


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.bench")
    ap.add_argument("--full", action="store_true", help="full mode (docs figures); default quick")
    ap.add_argument("--only", action="append", default=[], help="run only these groups")
    ap.add_argument("--json", default=None, help="write the rows as JSON to this file")
    ap.add_argument("--plot-dir", default=None, help="write plots (PNG) into this folder")
    args = ap.parse_args(argv)

    pkg_path = Path(__file__).parent
    for m in sorted(pkgutil.iter_modules([str(pkg_path)])):
        if m.name.startswith("bench_"):
            importlib.import_module(f"tests.bench.{m.name}")
    ctx = harness.Context(quick=not args.full, plot_dir=args.plot_dir)
    rows: list[harness.Row] = []
    for group, fn in harness.REGISTRY:
        if args.only and group not in args.only:
            continue
        print(f"== {group}: {fn.__name__}", file=sys.stderr, flush=True)
        rows.extend(fn(ctx))
    by_name = {(r.group, r.name): r for r in rows}
    for r in rows:
        if r.baseline and (r.group, r.baseline) in by_name and r.value:
            r.ratio = by_name[(r.group, r.baseline)].value / r.value
    w = max([len(r.name) for r in rows] + [10])
    print(f"{'group':10} {'benchmark':{w}} {'value':>12} {'unit':8} {'vs baseline':>12}  target / note")
    for r in rows:
        ratio = f"{r.ratio:10.2f}x" if r.ratio is not None else ""
        print(f"{r.group:10} {r.name:{w}} {r.value:12.4g} {r.unit:8} {ratio:>12}  {r.target} {r.note}".rstrip())
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps([asdict(r) for r in rows], indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
