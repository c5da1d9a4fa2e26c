"""Structure input (``--only load``, issue 16): reading and validating a structure file.

Structures: the tensegrity spine generator (8 members and one rigid body per vertebra), so
validation covers bodies as well as members. Per size, in the same run:

- the loader as it was before the schema layer, on the per-member YAML file (baseline):
  its two modules are read from the repository's history (commit ``OLD_COMMIT``) and run
  here only, against today's numpy; no row when git or the commit is not at hand;
- today's reader on the same YAML file, on the array form in JSON, and on the ``.npz`` file.

Quick: 2,000 members; full: 2,000, 10,000, 50,000 and 100,000 (the old loader takes about
17 s at 100,000). Target: the 100,000-member load well under a second (the whole
load + form-find + verdict budget there is 10 s). Times are this process's CPU time, best
of three (the old loader from 50,000 members, and every loader in quick mode: one run): the loaders run on one thread, and
CPU time does not count the other processes of a shared machine, which wall time does
(wall times of the same run varied by 5x).
"""

from __future__ import annotations

import gc
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

from tests.bench.harness import Context, Row, benchmark, no_gc

#: The last commit with the old structure loader (general/loading.py before tensegrity_core/schema).
OLD_COMMIT = "6c7b2ce"
ROOT = Path(__file__).resolve().parents[2]


def _old_load_structure():
    """The old ``load_structure`` (and the old ``Structure`` it validates with), rebuilt from
    the repository's history, or None."""
    def show(path: str) -> str:
        return subprocess.run(["git", "-C", str(ROOT), "show", f"{OLD_COMMIT}:{path}"], capture_output=True,
                              text=True, check=True, timeout=30).stdout

    try:
        structure_src = show("tensegrity_core/general/structure.py")
        loading_src = show("tensegrity_core/general/loading.py")
    except (OSError, subprocess.SubprocessError):
        return None
    modules = {}
    for name, src in (("_bench_old_structure", structure_src), ("_bench_old_loading", loading_src.replace(
            "from tensegrity_core.general.structure import", "from _bench_old_structure import"))):
        module = types.ModuleType(name)
        sys.modules[name] = module            # dataclasses look their module up while the class is made
        exec(compile(src, f"{OLD_COMMIT}:{name}", "exec"), module.__dict__)
        modules[name] = module
    return modules["_bench_old_loading"].load_structure


def _best_cpu(fn, repeat: int):
    """``(best CPU time [s], result)`` of ``fn()`` over ``repeat`` runs."""
    best, out = float("inf"), None
    for _ in range(repeat):
        gc.collect()
        with no_gc():
            t0 = time.process_time()
            out = fn()
            best = min(best, time.process_time() - t0)
    return best, out


def _spine(members: int):
    from tensegrity_core.general import tensegrity_spine

    return tensegrity_spine(members // 8 + 1, perturbation=0.03, seed=0)


@benchmark
def structure_files(ctx: Context) -> list[Row]:
    from tensegrity_core.general import save_structure, structure_from_file

    sizes = [2_000] if ctx.quick else [2_000, 10_000, 50_000, 100_000]
    repeat = 1 if ctx.quick else 3       # quick (CI's smoke run): every loader runs and reports, no speed proven
    old = _old_load_structure()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for m in sizes:
            s = _spine(m)
            tag = f"{s.n_members} members"
            paths = {fmt: save_structure(s, Path(tmp) / f"s{m}.{fmt}") for fmt in ("yaml", "json", "npz")}
            sizes_mb = {fmt: p.stat().st_size / 1e6 for fmt, p in paths.items()}
            baseline = None
            if old is not None:
                t_old, loaded = _best_cpu(lambda paths=paths: old(paths["yaml"]), repeat if s.n_members < 50_000 else 1)
                assert loaded.n_members == s.n_members
                baseline = f"old loader, YAML, {tag}"
                rows.append(Row("load", baseline, t_old, "s CPU",
                                note=f"{sizes_mb['yaml']:.1f} MB, commit {OLD_COMMIT}"))
            for fmt, label in (("yaml", "YAML per member"), ("json", "JSON array form"), ("npz", ".npz")):
                t, loaded = _best_cpu(lambda path=paths[fmt]: structure_from_file(path), repeat)
                assert loaded.n_members == s.n_members and loaded.bodies == s.bodies
                target = "< 1 s" if s.n_members >= 100_000 and fmt != "yaml" else ""
                rows.append(Row("load", f"{label}, {tag}", t, "s CPU", baseline=baseline, target=target,
                                note=f"{sizes_mb[fmt]:.1f} MB"))
    return rows
