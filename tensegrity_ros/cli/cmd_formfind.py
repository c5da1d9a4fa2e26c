"""``tensegrity formfind FILE`` and ``tensegrity modes FILE``: general tensegrity statics.

FILE is a structure description (YAML/TOML, see docs/structures.md) or the name of a
shipped example (``tensegrity formfind tensegrity_table``).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tensegrity_ros.cli._common import CliError, Subparsers, add_json_flag, print_json

ORDER = 40

if TYPE_CHECKING:
    from tensegrity_core.general import Structure
    from tensegrity_core.general.formfind_result import FormFindResult, IterationInfo


def register(subparsers: Subparsers) -> None:
    p = subparsers.add_parser(
        "formfind", help="find a stable equilibrium of a tensegrity structure with rigid bodies",
        description="Form-finding (shifted Newton with an energy line search, Ma et al. 2022). "
                    "Prints the result; exit code 1 if no stable equilibrium was found.")
    p.add_argument("file", help="structure file (.yaml/.toml) or the name of a shipped example")
    p.add_argument("--tol", type=float, default=None,
                   help="tolerance on the relative residual: out-of-balance force at a node over the forces "
                        "that meet there (dimensionless; default 1e-10)")
    p.add_argument("--max-iter", type=int, default=None, help="iteration limit")
    p.add_argument("--method", default="newton", help="newton (default) or dynamic_relaxation")
    p.add_argument("--linear-solver", choices=("auto", "dense", "sparse"), default="auto",
                   help="Newton's linear algebra (default: dense up to 300 DOF)")
    p.add_argument("-o", "--output", default=None, help="write the result to RESULT.yaml or RESULT.json")
    p.add_argument("--plot", default=None, help="write a picture of the initial and final shape (PNG)")
    p.add_argument("--quiet", action="store_true", help="no progress line")
    add_json_flag(p)
    p.set_defaults(func=run_formfind)

    q = subparsers.add_parser(
        "modes", help="rank, self-stress and mechanism modes of a structure's equilibrium matrix",
        description="SVD of the equilibrium matrix A_r (Eq. 67) at the drawn configuration, or "
                    "at the equilibrium with --at-equilibrium; with --stiffness also the lowest "
                    "eigenvalues of the tangent stiffness.")
    q.add_argument("file", help="structure file (.yaml/.toml) or the name of a shipped example")
    q.add_argument("--at-equilibrium", action="store_true", help="form-find first, analyse the equilibrium")
    q.add_argument("--stiffness", type=int, default=0, metavar="N",
                   help="also print the N lowest eigenvalues of K_T")
    add_json_flag(q)
    q.set_defaults(func=run_modes)


def _load(file: str) -> Structure:
    """The structure in ``file``, or the shipped example of that name."""
    from tensegrity_core.general import StructureError, example_names, load_example, structure_from_file
    from tensegrity_core.general.loading import SUFFIXES
    from tensegrity_core.schema import excerpt, suggest

    try:
        if file in example_names() and not _exists(file):
            return load_example(file)
        if not file.lower().endswith(SUFFIXES) and not _exists(file):
            raise CliError(f"no structure file or shipped example {excerpt(file)}"
                           f"{suggest(file, example_names())}; shipped examples: {', '.join(example_names())}")
        return structure_from_file(file)
    except StructureError as err:
        raise CliError(str(err)) from None


def _exists(file: str) -> bool:
    try:
        return Path(file).exists()
    except OSError:                          # e.g. a name longer than the system allows
        return False


def _progress(quiet: bool) -> tuple[Any, Callable[[IterationInfo], None] | None]:
    """A tqdm progress line on stderr and the callback that feeds it."""
    if quiet:
        return None, None
    from tqdm import tqdm

    bar = tqdm(desc="form-finding", unit="it", file=sys.stderr, leave=False, dynamic_ncols=True,
               mininterval=0)

    def callback(info: IterationInfo) -> None:
        shift = "" if info.shift is None else f" shift {info.shift:.1e}"
        bar.set_postfix_str(f"residual {info.residual:.3e} ({info.residual_norm:.3e} N), "
                            f"step {info.step_length:.3g}{shift}", refresh=False)
        bar.update(1)

    return bar, callback


def run_formfind(args: argparse.Namespace) -> int:
    from tensegrity_core.errors import TensegrityError
    from tensegrity_core.general import form_find

    structure = _load(args.file)
    out_path = Path(args.output) if args.output else None
    if out_path is not None and out_path.suffix.lower() not in (".yaml", ".yml", ".json"):
        raise CliError(f"-o/--output must end in .yaml, .yml or .json, got {str(out_path)!r}")
    options = {}
    if args.method.replace("-", "_") == "newton":
        options["linear_solver"] = args.linear_solver
    bar, callback = _progress(args.quiet or args.json)
    try:
        result = form_find(structure, method=args.method, tol=args.tol, max_iter=args.max_iter,
                           callback=callback, **options)
    except TensegrityError as err:
        raise CliError(str(err)) from None
    finally:
        if bar is not None:
            bar.close()
    data = result.to_dict()
    if out_path is not None:
        _write(out_path, data)
    if args.plot:
        from tensegrity_core.general.plotting import plot_shapes

        plot_shapes(structure, result.nodes, structure.nodes, path=args.plot,
                    title=f"{structure.name}: {result.message}")
    if args.json:
        print_json(data)
    else:
        _print_summary(structure, result)
    if not result.success:
        print(f"error: form-finding failed: {result.message}", file=sys.stderr)
        return 1
    return 0


def _write(path: Path, data: dict[str, Any]) -> None:
    import json

    import yaml

    try:
        if path.suffix.lower() == ".json":
            path.write_text(json.dumps(data, indent=2) + "\n")
        else:
            path.write_text(yaml.safe_dump(data, sort_keys=False, default_flow_style=None))
    except OSError as err:
        raise CliError(f"cannot write {str(path)!r}: {err.strerror}") from None


def residual_unit_of(structure: Structure) -> str:
    """The unit of the residual's norm: N over nodes; with rigid bodies their moments mix in N m."""
    return "N, N m" if structure.bodies else "N"


def k_unit(structure: Structure) -> str:
    """The unit of the eigenvalues of K_T: N/m over nodes; with rigid bodies their rotations
    mix in N m/rad (docs/general.md)."""
    return "N/m and N m/rad mixed" if structure.bodies else "N/m"


def answer_summary(answer: Any, structure: Structure | None) -> str:
    """One line of a ``find_form`` answer's numbers with their units (the ``FindForm`` response
    fields ``iterations``, ``residual``, ``residual_norm``, ``min_stiffness_eigenvalue``,
    ``stability_margin``) for ``structure``, the description it answered (None: one that was
    not read, taken as one without rigid bodies)."""
    residual_unit = "N" if structure is None else residual_unit_of(structure)
    eigenvalue_unit = "N/m" if structure is None else k_unit(structure)
    return (f"iterations {answer.iterations}, residual {answer.residual:.3g} (relative; norm "
            f"{answer.residual_norm:.3g} {residual_unit}), min stiffness eigenvalue "
            f"{answer.min_stiffness_eigenvalue:.4g} {eigenvalue_unit}, stability margin "
            f"{answer.stability_margin:.3g} (the scaled eigenvalue over its rounding level)")


def _print_summary(structure: Structure, result: FormFindResult) -> None:
    print(f"{structure.name}: {result.message}")
    if math.isfinite(result.min_eigenvalue):
        stability = (f"min eigenvalue of K_T [{k_unit(structure)}] {result.min_eigenvalue:.6g} "
                     f"({result.rigid_body_modes} rigid-body modes excluded), stability margin "
                     f"{result.stability_margin:.3g}")
    else:       # stopped before an equilibrium: the stability check did not run
        stability = "stability not checked"
    print(f"  iterations {result.iterations}, residual {result.residual:.3e} (relative; norm "
          f"{result.residual_norm:.3e} {residual_unit_of(structure)}), {stability}")
    if structure.n_members <= 60:
        print(f"  {'member':>12} {'force [N]':>14} {'length [m]':>12}")
        for name, t, length in zip(structure.member_names, result.member_forces, result.member_lengths):
            print(f"  {name:>12} {t:14.6g} {length:12.6g}")
    else:
        t = result.member_forces
        print(f"  {structure.n_members} members: force from {t.min():.6g} to {t.max():.6g} N")


def run_modes(args: argparse.Namespace) -> int:
    import numpy as np

    from tensegrity_core.general import form_find, modal_analysis, modes

    if args.stiffness < 0:
        raise CliError(f"--stiffness must be >= 0 (the number of eigenvalues to print), got {args.stiffness}")
    structure = _load(args.file)
    state = None
    if args.at_equilibrium:
        result = form_find(structure)
        if not result.success:
            raise CliError(f"form-finding failed: {result.message}", code=1)
        state = result.configuration
    m = modes(structure, state)
    data: dict[str, Any] = {
        "structure": structure.name,
        "dof": int(structure.layout.n_dof),
        "members": int(structure.n_members),
        "rank": int(m.rank),
        "self_stress_modes": int(m.self_stress.shape[1]),
        "mechanism_modes": int(m.mechanisms.shape[1]),
        "self_stress": [dict(zip(structure.member_names, np.round(col, 12).tolist())) for col in m.self_stress.T],
    }
    if args.stiffness:
        data["stiffness_eigenvalues"] = modal_analysis(structure, state, n_modes=args.stiffness).eigenvalues.tolist()
    if args.json:
        print_json(data)
        return 0
    print(f"{structure.name}: {data['dof']} DOF, {data['members']} members, rank of A_r {m.rank}: "
          f"{data['self_stress_modes']} self-stress mode(s), {data['mechanism_modes']} mechanism mode(s)")
    for k, col in enumerate(m.self_stress.T[:5]):
        print(f"  self-stress {k + 1}: " + ", ".join(f"{n} {v:.4f}" for n, v in zip(structure.member_names, col)))
    if args.stiffness:
        print(f"  lowest eigenvalues of K_T [{k_unit(structure)}]: "
              + ", ".join(f"{v:.6g}" for v in data["stiffness_eigenvalues"]))
    return 0
