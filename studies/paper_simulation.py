"""The simulation of the paper's Sect. 5.3, reproduced with the verified equations.

Scenario (Ji, Li & Lin, Sect. 5.3): L = 1 m, m = 2 kg, k1..k4 = 1 N/m, c1..c4 = 0.01 N s/m;
the mechanism starts at rest in equilibrium with rho1 = rho2 = 0.7 m and beta from the FKP
(:func:`~tensegrity_core.class2.energy.equilibrium_beta`: 0.7954 rad; the paper rounds it
to 0.8); actuator forces ``f1 = 10 rho1 t``, ``f2 = 10 rho2 t`` [N] (tensile positive, so
they pull the actuators shut and grow with time).

The integration is of the *unconstrained* equations of motion: nothing stops an actuator
at zero length. :func:`simulate_paper` records when each actuator length first reaches
zero (solve_ivp events) and keeps integrating, so the figures show what the equations do
afterwards. :func:`plot_paper_figures` draws the paper's Figs. 3-7 as PNGs;
``python -m studies.paper_simulation [OUTDIR]`` writes them (default
``docs/img/class2``). Findings are in ``docs/design/class2_dynamics.md``.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Final

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import solve_ivp

from tensegrity_core.class2.dynamics import ActuatorLengthEvent, Class2Dynamics, mechanical_energy
from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.errors import ConvergenceError, ParameterError

if TYPE_CHECKING:
    from matplotlib.axes import Axes

#: The paper's force-law gain [N/(m s)]: f_i = GAIN * rho_i * t.
PAPER_GAIN: Final = 10.0
#: The paper's claim: folded configuration q_F reached at about this time [s].
PAPER_FOLD_TIME: Final = 2.5


@dataclass(frozen=True)
class PaperSimulation:
    """Result of :func:`simulate_paper`; arrays sampled at ``t``.

    ``y`` (N, 6): the state; ``f`` (N, 2): actuator forces [N]; ``x, y_d``: end-effector D
    from the dynamic state (Eqs. 3-4); ``x0, y0``: the equilibrium (FKP) position of D for the
    current actuator lengths, NaN while an actuator length is negative (no configuration);
    ``energy``: T + U [J]; ``zero_crossings``: times at which rho1 / rho2 pass through zero
    (either direction); ``first_zero``: the first such time per actuator (None if never).
    """

    t: NDArray[np.float64]
    y: NDArray[np.float64]
    f: NDArray[np.float64]
    x: NDArray[np.float64]
    y_d: NDArray[np.float64]
    x0: NDArray[np.float64]
    y0: NDArray[np.float64]
    energy: NDArray[np.float64]
    beta0: float
    zero_crossings: dict[str, NDArray[np.float64]]
    first_zero: dict[str, float | None]
    params: Class2Params
    gain: float
    nfev: int


def paper_forces(t: float, rho1: float, rho2: float, gain: float = PAPER_GAIN) -> tuple[float, float]:
    """``(f1, f2) = (gain rho1 t, gain rho2 t)`` [N], the paper's actuator force law."""
    return gain * rho1 * t, gain * rho2 * t


def simulate_paper(t_end: float = 5.0, *, params: Class2Params = PAPER_PARAMS, rho0: tuple[float, float] = (0.7, 0.7),
                   beta0: float | None = None, gain: float = PAPER_GAIN, method: str = "DOP853",
                   rtol: float = 1e-10, atol: float = 1e-12, samples: int = 2001) -> PaperSimulation:
    """Integrate the paper's scenario from rest on ``[0, t_end]`` s.

    ``beta0=None`` starts in equilibrium (FKP beta); pass 0.8 for the paper's rounded value.
    ``method`` is any solve_ivp method; implicit ones (Radau, BDF, LSODA) get the analytic
    Jacobian including the force law's ``d f / d y``.
    """
    if not (np.isfinite(t_end) and t_end > 0):
        raise ParameterError(f"t_end must be a positive number of seconds, got {t_end!r}")
    if not (isinstance(samples, int) and samples >= 2):
        raise ParameterError(f"samples must be an integer >= 2, got {samples!r}")
    dyn = Class2Dynamics(params)
    r10, r20 = (float(v) for v in rho0)
    b0 = float(equilibrium_beta(r10, r20, params)) if beta0 is None else float(beta0)

    def rhs(t: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
        f1, f2 = paper_forces(t, y[0], y[1], gain)
        return dyn.rhs(t, y, f1, f2)

    def jac(t: float, y: NDArray[np.float64]) -> NDArray[np.float64]:
        dfy = np.zeros((2, 6))
        dfy[0, 0] = dfy[1, 1] = gain * t
        f1, f2 = paper_forces(t, y[0], y[1], gain)
        return dyn.jacobian(t, y, f1, f2, dforce_dy=dfy)

    events = [ActuatorLengthEvent(1, terminal=False, direction=0.0),
              ActuatorLengthEvent(2, terminal=False, direction=0.0)]
    t_eval = np.linspace(0.0, t_end, samples)
    kw = {"jac": jac} if method in ("Radau", "BDF", "LSODA") else {}
    sol = solve_ivp(rhs, (0.0, t_end), [r10, r20, b0, 0.0, 0.0, 0.0], method=method, t_eval=t_eval,
                    events=events, rtol=rtol, atol=atol, **kw)
    if not sol.success:
        raise ConvergenceError(f"solve_ivp ({method}) failed at t = {sol.t[-1]:.6g} s: {sol.message}", result=sol)

    y = sol.y.T
    rho1, rho2, beta = y[:, 0], y[:, 1], y[:, 2]
    f = np.stack(paper_forces(sol.t, rho1, rho2, gain), -1)
    physical = (rho1 >= 0) & (rho2 >= 0)
    beta_eq = np.where(physical, equilibrium_beta(np.abs(rho1), np.abs(rho2), params), np.nan)
    crossings = {"rho1": sol.t_events[0], "rho2": sol.t_events[1]}
    # A start exactly at zero length is not a crossing.
    crossings = {k: v[v > 0.0] for k, v in crossings.items()}
    return PaperSimulation(
        t=sol.t, y=y, f=f,
        x=rho1 + params.L * np.cos(beta), y_d=params.L * np.sin(beta),
        x0=rho1 + params.L * np.cos(beta_eq), y0=params.L * np.sin(beta_eq),
        energy=mechanical_energy(y[:, :3], y[:, 3:], params),
        beta0=b0, zero_crossings=crossings,
        first_zero={k: (float(v[0]) if v.size else None) for k, v in crossings.items()},
        params=params, gain=gain, nfev=int(sol.nfev),
    )


def _mark_zeros(ax: Axes, sim: PaperSimulation) -> None:
    for name, style in (("rho1", ":"), ("rho2", "--")):
        t0 = sim.first_zero[name]
        if t0 is not None:
            ax.axvline(t0, color="tab:red", ls=style, lw=0.8, label=f"{name} first reaches 0 ({t0:.3f} s)")
    ax.axvline(PAPER_FOLD_TIME, color="0.5", lw=0.8, label=f"paper: folded at {PAPER_FOLD_TIME} s")


def plot_paper_figures(outdir: str | Path, sim: PaperSimulation | None = None, *,
                       long_sim: PaperSimulation | None = None) -> list[Path]:
    """Write the paper's Figs. 3-7 (and a long-run overview) as PNGs into ``outdir``.

    ``sim`` defaults to :func:`simulate_paper` on 0-5 s; ``long_sim`` to 0-60 s. Returns
    the written paths.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sim = sim or simulate_paper()
    long_sim = long_sim or simulate_paper(60.0, samples=24001, rtol=1e-9, atol=1e-11)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    specs = [
        ("fig3_rho1.png", "Fig. 3: actuator length rho1", "rho1 [m]", [(sim.y[:, 0], "rho1 (dynamics)", "-")], 0.0),
        ("fig4_rho2.png", "Fig. 4: actuator length rho2", "rho2 [m]", [(sim.y[:, 1], "rho2 (dynamics)", "-")], 0.0),
        ("fig5_beta.png", "Fig. 5: angle beta", "beta [rad]", [(sim.y[:, 2], "beta (dynamics)", "-")], np.pi / 2),
        ("fig6_x.png", "Fig. 6: end-effector x", "x [m]",
         [(sim.x, "x1 (dynamics)", "-"), (sim.x0, "x0 (equilibrium of current rho)", "--")], 0.0),
        ("fig7_y.png", "Fig. 7: end-effector y", "y [m]",
         [(sim.y_d, "y1 (dynamics)", "-"), (sim.y0, "y0 (equilibrium of current rho)", "--")], 1.0),
    ]
    for name, title, ylabel, curves, q_f in specs:
        fig, ax = plt.subplots(figsize=(7, 4))
        for values, label, style in curves:
            ax.plot(sim.t, values, style, label=label)
        ax.axhline(q_f, color="0.3", lw=0.8, ls="-.", label=f"paper's folded value {q_f:.4g}")
        _mark_zeros(ax, sim)
        ax.set(title=title + " (unconstrained equations)", xlabel="t [s]", ylabel=ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
        path = out / name
        fig.savefig(path, dpi=110)
        plt.close(fig)
        paths.append(path)

    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for ax, i, label in zip(axes, range(3), ("rho1 [m]", "rho2 [m]", "beta [rad]")):
        ax.plot(long_sim.t, long_sim.y[:, i], lw=0.6)
        ax.axhline(np.pi / 2 if i == 2 else 0.0, color="0.3", lw=0.8, ls="-.")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_title("Long run of the unconstrained equations (f_i = 10 rho_i t): no fold, "
                      "oscillation through zero length", fontsize=9)
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    path = out / "long_run.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    paths.append(path)
    return paths


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    outdir = Path(argv[0]) if argv else Path(__file__).resolve().parents[2] / "docs" / "img" / "class2"
    sim = simulate_paper()
    print(f"beta0 (FKP) = {sim.beta0:.6f} rad")
    for name in ("rho1", "rho2"):
        print(f"{name} first reaches zero at t = {sim.first_zero[name]} s; "
              f"crossings in [0, 5] s: {np.round(sim.zero_crossings[name], 4).tolist()}")
    for path in plot_paper_figures(outdir, sim):
        print("wrote", path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
