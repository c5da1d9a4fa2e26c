"""Class-2 mechanism quick answers: ``fk``, ``ik``, ``stiffness``, ``workspace``, ``singularities``.

Human-readable by default, ``--json`` for scripts; ``--param NAME=VALUE`` overrides the
paper's parameters (``k=`` sets k1..k4, ``c=`` sets c1..c4). Out-of-domain input exits
with code 2 and one ``error:`` line.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, TypeVar

from tensegrity_ros.cli._common import CliError, Subparsers, add_json_flag, parse_param_overrides, print_json

if TYPE_CHECKING:
    from tensegrity_core.class2 import Class2Params
    from tensegrity_core.class2.workspace import Curve

ORDER = 20
T = TypeVar("T")


def _params(args: argparse.Namespace) -> Class2Params:
    from tensegrity_core.class2 import PAPER_PARAMS
    from tensegrity_core.errors import TensegrityError

    try:
        return PAPER_PARAMS.with_overrides(parse_param_overrides(args.param))
    except TensegrityError as err:
        raise CliError(str(err)) from None


def _run(fn: Callable[[], T]) -> T:
    """Turn the core's deliberate errors into one-line CLI errors."""
    from tensegrity_core.errors import TensegrityError

    try:
        return fn()
    except TensegrityError as err:
        raise CliError(str(err)) from None


#: The most points a sweep or a workspace boundary curve may have: 10,000 take ~10 s of CPU
#: (one stiffness solve or one boundary point each); a count of 1e8 ran for hours in silence.
MAX_POINTS = 10_000


def _check_points(points: int) -> None:
    if not 2 <= points <= MAX_POINTS:
        raise CliError(f"--points must be between 2 and {MAX_POINTS}, got {points}")


def _common(p: argparse.ArgumentParser) -> None:
    add_json_flag(p)
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="override a mechanism parameter (L, k1..k4, k, ka, kb, m, c1..c4, c); repeatable")


def _deg(rad: float) -> str:
    return f"{rad:.6g} rad ({math.degrees(rad):.4g} deg)"


def cmd_fk(args: argparse.Namespace) -> int:
    from tensegrity_core.class2.kinematics import forward_kinematics, forward_kinematics_numeric

    params = _params(args)
    solve = forward_kinematics_numeric if args.numeric else forward_kinematics
    fk = _run(lambda: solve(args.rho1, args.rho2, params))
    cond = fk.jacobian_cond
    if args.json:
        print_json({**fk.as_dict(), "jacobian_cond": cond, "method": "numeric" if args.numeric else "closed form",
                    "params": params.as_dict()})
        return 0
    how = "energy minimisation (numeric)" if args.numeric else "closed form, energy minimum of Eq. 10"
    print(f"forward kinematics ({how})")
    print(f"  rho1 = {fk.rho1:g} m, rho2 = {fk.rho2:g} m")
    print(f"  beta  = {_deg(fk.beta)}")
    print(f"  alpha = {_deg(fk.alpha)}")
    print(f"  D     = ({fk.x:.10g}, {fk.y:.10g}) m")
    print(f"  d2U/dbeta2 = {fk.stiffness_beta:.6g} J/rad^2 ({'stable' if fk.stable else 'NOT stable'})")
    print(f"  in the paper's range 0 <= alpha, beta <= pi/2: {'yes' if fk.in_paper_range else 'no'}")
    print(f"  nearest singular set: {fk.nearest_singularity} at distance {fk.singularity_distance:.4g} "
          f"(actuator plane / L); cond(dD/drho) = {cond:.4g}")
    if fk.note:
        print(f"  note: {fk.note}")
    return 0


def cmd_ik(args: argparse.Namespace) -> int:
    from tensegrity_core.class2.inverse_kinematics import inverse_kinematics
    from tensegrity_core.class2.kinematics import as_real

    params = _params(args)
    res = _run(lambda: inverse_kinematics(args.x, args.y, params, paper_range=args.paper_range))
    shown = list(res.candidates if args.all else res.valid)
    seed = args.seed and _run(lambda: (as_real("seed rho1", args.seed[0]), as_real("seed rho2", args.seed[1])))
    dist = {}
    if seed:
        dist = {id(c): math.hypot(c.rho1 - seed[0], c.rho2 - seed[1]) for c in shown}
        shown.sort(key=lambda c: (not c.valid, dist[id(c)] if math.isfinite(dist[id(c)]) else math.inf))
    if args.json:
        rows = [{**c.as_dict(), **({"distance_to_seed": dist[id(c)]} if seed else {})} for c in shown]
        print_json({"x": res.x, "y": res.y, "paper_range": res.paper_range, "success": res.success,
                    "message": res.message, "outside_distance": res.outside_distance, "solutions": rows})
    else:
        print(f"inverse kinematics for D = ({res.x:g}, {res.y:g}) m "
              f"({'paper range 0 <= beta <= pi/2' if res.paper_range else 'any stable equilibrium'}): {res.message}")
        if shown:
            head = f"  {'d1':>3} {'d2':>3} {'rho1 [m]':>12} {'rho2 [m]':>12} {'beta [rad]':>11}  {'range':5}"
            print(head + ("  seed dist [m]" if seed else "") + "  verdict")
        for c in shown:
            line = (f"  {c.delta1:+3d} {c.delta2:+3d} {c.rho1:12.8g} {c.rho2:12.8g} {c.beta:11.6g}  "
                    f"{'yes' if c.in_paper_range else 'no':5}")
            if seed:
                line += f"  {dist[id(c)]:13.4g}"
            print(line + "  " + ("valid" if c.valid else c.reason))
    if not res.success:
        raise CliError(res.message)
    return 0


def cmd_stiffness(args: argparse.Namespace) -> int:
    import numpy as np

    from tensegrity_core.class2.stiffness import stiffness_along_coordinates, stiffness_sweep

    params = _params(args)
    if args.sweep is not None:
        fmin, fmax = args.sweep
        if not (math.isfinite(fmin) and math.isfinite(fmax)) or fmax <= fmin:
            raise CliError(f"--sweep needs finite FMIN < FMAX, got {fmin:g} {fmax:g}")
        _check_points(args.points)
        sweep = _run(lambda: stiffness_sweep(args.rho1, args.rho2, np.linspace(fmin, fmax, args.points), params))
        if args.plot:
            from tensegrity_core.class2.plotting import plot_stiffness_sweep

            plot_stiffness_sweep(sweep, args.plot)
        if args.json:
            print_json({**sweep, "plot": args.plot})
        else:
            names = sweep["coordinates"]
            print(f"stiffness along x_r at rho1 = {sweep['rho1']:g} m, rho2 = {sweep['rho2']:g} m, "
                  f"beta = {sweep['beta']:.6g} rad; f on F along +Y [N], K_i [N/m]")
            print(f"  {'f':>9} " + " ".join(f"{'K' + str(i + 1) + ' ' + n:>11}" for i, n in enumerate(names))
                  + f" {'min eig K':>11}")
            for fv, row, low in zip(sweep["f"], sweep["K_i"], sweep["min_eigenvalue"]):
                print(f"  {fv:9.4g} " + " ".join(f"{v:11.5g}" for v in row) + f" {low:11.5g}")
            if np.any(sweep["min_eigenvalue"] < 0):
                print("  where min eig K < 0 the framework is unstable: those K_i are no stiffnesses")
            if args.plot:
                print(f"plot written to {args.plot}")
        return 0
    res = _run(lambda: stiffness_along_coordinates(args.rho1, args.rho2, args.f, params, beta=args.beta))
    if args.plot:
        raise CliError("--plot needs --sweep FMIN FMAX (the plot is K_i against f)")
    if args.json:
        print_json(res.as_dict())
        return 0
    from tensegrity_core.class2.geometry import MEMBERS

    print(f"stiffness at rho1 = {res.rho1:g} m, rho2 = {res.rho2:g} m, beta = {res.beta:.6g} rad, "
          f"f = {res.f:g} N on F along +Y")
    print(f"  {'i':>2} {'coord':>5} {'K_i [N/m]':>12} {'cond(K_ri)':>11}")
    for i, (name, k, c) in enumerate(zip(res.coordinates, res.K_i, res.cond_K_r)):
        print(f"  {i + 1:2d} {name:>5} {k:12.6g} {c:11.4g}")
    print("  member forces (tension > 0) [N]: " + ", ".join(f"{m.label} {t:.5g}" for m, t in zip(MEMBERS, res.t)))
    print(f"  equilibrium residual max|A_r t - f_r| = {res.equilibrium_residual:.3g} N"
          + ("" if args.beta is None else " (beta given: zero only at the FKP equilibrium)"))
    print(f"  smallest eigenvalue of K = {res.min_eigenvalue:.6g} N/m"
          + (" (positive definite)" if res.min_eigenvalue > 0 else
             ": K is not positive definite, the framework (elastic actuators and struts) is unstable "
             "here and the K_i above are no stiffnesses a load could measure"))
    return 0


def cmd_workspace(args: argparse.Namespace) -> int:
    from tensegrity_core.class2.workspace import workspace

    params = _params(args)
    _check_points(args.points)
    ws = _run(lambda: workspace(params, args.rho1_range, args.rho2_range,
                                paper_range=args.paper_range, n=args.points))
    area = ws.area()
    if args.plot:
        from tensegrity_core.class2.plotting import plot_workspace

        plot_workspace(ws, args.plot)
    if args.json:
        def curve(c: Curve) -> dict[str, object]:
            return {"kind": c.kind, "label": c.label, "rho": c.rho, "xy": c.xy, "on_boundary": c.on_boundary}

        print_json({"rho1_range": ws.rho1_range, "rho2_range": ws.rho2_range, "paper_range": ws.paper_range,
                    "area": area, "bounds": ws.bounds(), "polygon": ws.polygon,
                    "edges": [curve(c) for c in ws.edges],
                    "singular_curves": [curve(c) for c in ws.singular_curves], "plot": args.plot})
        return 0
    print(f"workspace of D for rho1 in [{ws.rho1_range[0]:g}, {ws.rho1_range[1]:g}] m, rho2 in "
          f"[{ws.rho2_range[0]:g}, {ws.rho2_range[1]:g}] m "
          f"({'paper range beta <= pi/2' if ws.paper_range else 'all stable equilibria'})")
    print(f"  area = {area:.6g} m^2" + ("" if ws.paper_range else " (grid estimate)"))
    x0, x1, y0, y1 = ws.bounds()
    print(f"  bounding box: x in [{x0:.6g}, {x1:.6g}] m, y in [{y0:.6g}, {y1:.6g}] m")
    print("  boundary candidates (images of the actuator polygon's edges):")
    for c in ws.edges:
        print(f"    {c.label}: D from ({c.xy[0, 0]:.5g}, {c.xy[0, 1]:.5g}) to ({c.xy[-1, 0]:.5g}, {c.xy[-1, 1]:.5g}), "
              f"{100 * c.on_boundary.mean():.0f}% on the boundary")
    print("  singular sets inside the limits:")
    for c in ws.singular_curves:
        if len(c.xy) == 1:
            print(f"    {c.label}: D = ({c.xy[0, 0]:.5g}, {c.xy[0, 1]:.5g})")
        else:
            print(f"    {c.label}: D from ({c.xy[0, 0]:.5g}, {c.xy[0, 1]:.5g}) to ({c.xy[-1, 0]:.5g}, {c.xy[-1, 1]:.5g})")
    if args.plot:
        print(f"plot written to {args.plot}")
    return 0


def cmd_singularities(args: argparse.Namespace) -> int:
    from tensegrity_core.class2.singularities.report import classify_singularities

    params = _params(args)
    rep = _run(lambda: classify_singularities(args.rho1, args.rho2, params))
    if args.json:
        print_json(rep.as_dict())
        return 0
    print(f"singular sets near rho1 = {rep.rho1:g} m, rho2 = {rep.rho2:g} m (beta = {rep.beta:.6g} rad, "
          f"D = ({rep.x:.6g}, {rep.y:.6g}) m); cond(dD/drho) = {rep.jacobian_cond:.4g}")
    print(f"  {'set':16} {'distance/L':>10}  {'value':20}  meaning")
    for s in rep.sets:
        print(f"  {s.kind:16} {s.distance:10.4g}  {_with_unit(s.value, s.unit):20}  {s.description}")
    return 0


def _with_unit(value: float, unit: str) -> str:
    """``0.46365 rad``; a multiple of the strut length as ``0.71414 x L``."""
    return f"{value:.5g} x {unit}" if unit.endswith("L") else f"{value:.5g} {unit}"


def register(sub: Subparsers) -> None:
    p = sub.add_parser("fk", help="class-2 forward kinematics: node D for actuator lengths")
    p.add_argument("rho1", type=float, help="actuator length AB [m]")
    p.add_argument("rho2", type=float, help="actuator length BC [m]")
    p.add_argument("--numeric", action="store_true", help="solve by numeric energy minimisation")
    _common(p)
    p.set_defaults(func=cmd_fk)

    p = sub.add_parser("ik", help="class-2 inverse kinematics: actuator lengths for node D")
    p.add_argument("x", type=float, help="x of node D [m]")
    p.add_argument("y", type=float, help="y of node D [m]")
    p.add_argument("--seed", type=float, nargs=2, metavar=("RHO1", "RHO2"),
                   help="current actuator lengths: order solutions nearest first")
    p.add_argument("--all", action="store_true", help="show every candidate of the quartic route with its verdict")
    p.add_argument("--paper-range", action=argparse.BooleanOptionalAction, default=True,
                   help="only solutions with 0 <= beta <= pi/2 are valid (default: yes)")
    _common(p)
    p.set_defaults(func=cmd_ik)

    p = sub.add_parser("stiffness", help="class-2 stiffness along the nodal coordinates (paper Sect. 4)")
    p.add_argument("rho1", type=float, help="actuator length AB [m]")
    p.add_argument("rho2", type=float, help="actuator length BC [m]")
    p.add_argument("--f", type=float, default=0.0, help="force on node F along +Y [N] (default 0)")
    p.add_argument("--beta", type=float, default=None,
                   help="angle of BD [rad] (default: the FKP equilibrium)")
    p.add_argument("--sweep", type=float, nargs=2, metavar=("FMIN", "FMAX"), help="tabulate K_i(f) over [FMIN, FMAX]")
    p.add_argument("--points", type=int, default=36, help="points of the sweep (2-10000, default 36)")
    p.add_argument("--plot", metavar="FILE.png", help="with --sweep: plot K_i(f) as the paper's Fig. 2")
    _common(p)
    p.set_defaults(func=cmd_stiffness)

    p = sub.add_parser("workspace", help="class-2 workspace of node D for actuator limits")
    p.add_argument("--rho1-range", type=float, nargs=2, metavar=("A", "B"), help="limits of rho1 [m]")
    p.add_argument("--rho2-range", type=float, nargs=2, metavar=("A", "B"), help="limits of rho2 [m]")
    p.add_argument("--paper-range", action=argparse.BooleanOptionalAction, default=True,
                   help="count only equilibria with beta <= pi/2 (default: yes)")
    p.add_argument("--points", type=int, default=200, help="points per boundary curve (2-10000, default 200)")
    p.add_argument("--plot", metavar="FILE.png", help="draw the reachable set, boundary and singular curves")
    _common(p)
    p.set_defaults(func=cmd_workspace)

    p = sub.add_parser("singularities", help="class-2 singular sets near a configuration, with distances")
    p.add_argument("rho1", type=float, help="actuator length AB [m]")
    p.add_argument("rho2", type=float, help="actuator length BC [m]")
    _common(p)
    p.set_defaults(func=cmd_singularities)
