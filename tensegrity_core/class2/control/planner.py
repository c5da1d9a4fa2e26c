"""Planning an end-effector move: a straight line for D, checked by IK along it.

``plan_move(q_start, (x, y), params, duration=..., max_speed=...)``:

1. the target must be reachable (:func:`~tensegrity_core.class2.inverse_kinematics`);
2. D moves from where it is to the target along a straight line with the rest-to-rest
   scaling of :mod:`~tensegrity_core.class2.control.paths`; its duration is the given one,
   or the one that keeps D's peak speed at ``max_speed`` (the longer when both are given);
   ``max_speed`` alone is a limit, not a demand: a move whose feedforward at that speed
   would exceed ``force_budget`` takes the shortest duration within it instead (step 4);
3. IK along the line at least every ``ik_spacing`` metres, each solve seeded with the
   previous solution (:func:`~tensegrity_core.class2.nearest_solution`, branch continuity):
   a sample outside the workspace, a jump of branch, or one nearer than
   ``singular_margin`` (actuator plane, relative to L) to a singular set refuses the move
   with the place and the set;
4. the dynamically consistent reference (:mod:`~tensegrity_core.class2.control.flat`),
   whose feedforward must stay within ``force_budget`` [N]: a given duration over it is
   refused, naming the shortest duration that fits.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Final

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.class2.control.errors import INVALID_GOAL, OUTSIDE_WORKSPACE, SINGULAR_PATH, PlanningError
from tensegrity_core.class2.control.flat import end_effector_reference
from tensegrity_core.class2.control.paths import PEAK_SPEED_FACTOR, EndEffectorPath, LinePath, MeasuredPath
from tensegrity_core.class2.control.reference import Reference, hold_reference
from tensegrity_core.class2.inverse_kinematics import inverse_kinematics, nearest_solution
from tensegrity_core.class2.kinematics import jacobian_D_rho
from tensegrity_core.class2.params import Class2Params
from tensegrity_core.class2.singularities.distances import nearest_singularity
from tensegrity_core.errors import TensegrityError

#: Default margin to the singular sets [L]: the IK node reports distances in the same measure.
SINGULAR_MARGIN: Final = 0.02
#: IK samples at least this often along a path [m].
IK_SPACING: Final = 0.001
#: A branch jump: consecutive IK solutions further apart than this many times what the
#: local gain |drho/dD| allows for the step (the genuine branch moves smoothly).
_BRANCH_JUMP: Final = 10.0


def _finite(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise PlanningError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def move_duration(length: float, duration: float | None, max_speed: float | None) -> float:
    """The move's duration [s] from a duration and/or a peak-speed limit [m/s] (see the
    module docstring); both ``None`` or ``<= 0`` is refused."""
    given: list[float] = []
    if duration is not None:
        duration = _finite("duration", duration)
        if duration <= 0.0:
            raise PlanningError(f"duration must be > 0 s, got {duration:g} s")
        given.append(duration)
    if max_speed is not None:
        max_speed = _finite("max_speed", max_speed)
        if max_speed <= 0.0:
            raise PlanningError(f"max_speed must be > 0 m/s, got {max_speed:g} m/s")
        given.append(PEAK_SPEED_FACTOR * length / max_speed)
    if not given:
        raise PlanningError("give a duration (> 0 s) or a speed limit max_speed (> 0 m/s)")
    return max(given)


def check_path_ik(path: MeasuredPath, rho_seed: Sequence[float] | NDArray[np.float64], params: Class2Params, *,
                  singular_margin: float = SINGULAR_MARGIN,
                  spacing: float = IK_SPACING) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """IK along ``path.point(sigma)`` with branch continuity from ``rho_seed``; returns the
    path parameters and the solutions (n, 2), or raises :class:`PlanningError` naming the
    first bad sample."""
    n = max(2, int(math.ceil(path.length / spacing)) + 1)
    sigma = np.linspace(0.0, 1.0, n)
    points = path.point(sigma)
    rho = np.empty((n, 2))
    seed: tuple[float, float] = (float(rho_seed[0]), float(rho_seed[1]))
    for i, (x, y) in enumerate(points):
        try:
            c = nearest_solution(float(x), float(y), seed, params)
        except TensegrityError as err:
            raise PlanningError(f"the path leaves the workspace at D = ({x:.4f}, {y:.4f}) m: {err}",
                                code=OUTSIDE_WORKSPACE) from None
        name, dist = nearest_singularity(c.rho1, c.rho2, params)
        if dist < singular_margin:
            raise PlanningError(
                f"the path passes within {dist:.3g} L of the singular set {name} at D = ({x:.4f}, {y:.4f}) m "
                f"(rho = ({c.rho1:.4f}, {c.rho2:.4f}) m; the margin is {singular_margin:g} L)",
                code=SINGULAR_PATH)
        if i > 0:
            step = math.dist(points[i], points[i - 1])
            jump = math.dist((c.rho1, c.rho2), seed)
            gain = np.linalg.norm(np.linalg.inv(jacobian_D_rho(*seed, params)), 2)   # |drho/dD|
            if jump > _BRANCH_JUMP * gain * step + 1e-9 * params.L:
                raise PlanningError(f"the IK solution jumps by {jump:.3g} m between neighbouring path points "
                                    f"at D = ({x:.4f}, {y:.4f}) m (a change of branch)", code=SINGULAR_PATH)
        rho[i] = (c.rho1, c.rho2)
        seed = (c.rho1, c.rho2)
    return sigma, rho


def plan_move(q_start: Sequence[float] | NDArray[np.float64], target: Sequence[float], params: Class2Params, *,
              duration: float | None = None,
              max_speed: float | None = None, force_budget: float = math.inf,
              singular_margin: float = SINGULAR_MARGIN, step: float = 0.002) -> Reference:
    """The reference for moving D from its place at ``q_start`` (rho1, rho2, beta) to
    ``target`` (x, y) [m]; see the module docstring. Raises :class:`PlanningError`."""
    x, y = _finite("x", target[0]), _finite("y", target[1])
    q0 = [float(v) for v in q_start]
    L = params.L
    ik = inverse_kinematics(x, y, params)
    if not ik.success:
        raise PlanningError(f"target D = ({x:g}, {y:g}) m is not reachable: {ik.message}", code=OUTSIDE_WORKSPACE)
    goal = ik.valid[0]
    name, dist = nearest_singularity(goal.rho1, goal.rho2, params)
    if dist < singular_margin:
        raise PlanningError(f"target D = ({x:g}, {y:g}) m lies within {dist:.3g} L of the singular set {name} "
                            f"(the margin is {singular_margin:g} L)", code=SINGULAR_PATH)
    start = (q0[0] + L * math.cos(q0[2]), L * math.sin(q0[2]))
    length = math.dist(start, (x, y))
    T = move_duration(length, duration, max_speed)
    if length < 1e-9 * L:
        return _hold_for(goal.rho1, goal.rho2, T, params, (x, y))
    return plan_path(LinePath(start, (x, y), T), q0, params, force_budget=force_budget,
                     singular_margin=singular_margin, step=step, target=(x, y),
                     retimed=lambda duration: LinePath(start, (x, y), duration), stretch=duration is None)


def plan_path(path: MeasuredPath, q_start: Sequence[float] | NDArray[np.float64], params: Class2Params, *,
              force_budget: float = math.inf, singular_margin: float = SINGULAR_MARGIN, step: float = 0.002,
              target: tuple[float, float] | None = None,
              retimed: Callable[[float], MeasuredPath] | None = None, stretch: bool = False) -> Reference:
    """The reference for D along ``path`` (a :class:`LinePath`, :class:`CirclePath`, ...)
    starting where ``q_start`` puts D: IK along it (steps 3-4 of the module docstring).
    ``retimed(duration)`` (the same path in another duration), when given, lets a refusal for
    the force budget say the shortest duration within it (:func:`shortest_duration`), or,
    with ``stretch`` (the path's duration came from a speed limit, not from the caller), be
    replaced by the reference over that duration."""
    sigma, rho = check_path_ik(path, q_start[:2], params, singular_margin=singular_margin)

    def reference(p: MeasuredPath) -> Reference:
        def guess(t: NDArray[np.float64]) -> NDArray[np.float64]:   # static IK along the path
            return np.interp(p.sigma(t), sigma, rho[:, 1])

        return end_effector_reference(p, params, guess, step=step, target=target)

    ref = reference(path)
    peak = float(np.max(np.abs(ref.force)))
    if peak <= force_budget:
        return ref
    advice = "allow more time"
    if retimed is not None:
        def fits(duration: float) -> bool:
            try:
                return float(np.max(np.abs(reference(retimed(duration)).force))) <= force_budget
            except PlanningError:      # too fast for a reference at all
                return False

        enough = shortest_duration(fits, path.duration)
        if stretch and enough is not None:
            slower = reference(retimed(enough))
            if float(np.max(np.abs(slower.force))) <= force_budget:
                return slower
        advice = (f"allow more time: a duration of at least {enough:.3g} s (a peak speed of D of at most "
                  f"{_round_down(peak_speed(retimed(enough))):.3g} m/s) keeps it within the budget"
                  if enough is not None else
                  f"no duration up to {path.duration * 2 ** _MAX_DOUBLINGS:.3g} s keeps it within the budget: "
                  "holding the path's configurations alone needs more")
    raise PlanningError(f"the move needs feedforward forces up to {peak:.3g} N in {path.duration:g} s, over "
                        f"the budget of {force_budget:g} N: {advice}", code=INVALID_GOAL)


#: How far :func:`shortest_duration` looks: up to 2**this times the refused duration.
_MAX_DOUBLINGS: Final = 6


def shortest_duration(fits: Callable[[float], bool], refused: float, *, rel: float = 0.02) -> float | None:
    """The shortest duration [s] longer than ``refused`` for which ``fits(duration)``, to a
    relative ``rel`` and rounded up to 3 significant digits (so the number said is one that
    fits), assuming longer durations fit once one does; None when none up to
    ``refused * 2**6`` does. Doubles from ``refused``, then bisects (geometrically)."""
    low, high = refused, refused
    for _ in range(_MAX_DOUBLINGS):
        high = 2.0 * low
        if fits(high):
            break
        low = high
    else:
        return None
    while high / low > 1.0 + rel:
        middle = math.sqrt(low * high)
        low, high = (low, middle) if fits(middle) else (middle, high)
    digits = 2 - math.floor(math.log10(high))
    return math.ceil(high * 10.0**digits) / 10.0**digits


def _round_down(value: float) -> float:
    """``value`` > 0 rounded down to 3 significant digits (a limit said is then one that holds)."""
    digits = 2 - math.floor(math.log10(value))
    return math.floor(value * 10.0**digits) / 10.0**digits


def peak_speed(path: EndEffectorPath, samples: int = 2001) -> float:
    """The largest speed of D along ``path`` [m/s], sampled ``samples`` times."""
    _, velocity, _ = path.sample(np.linspace(0.0, path.duration, samples))
    return float(np.max(np.hypot(velocity[:, 0], velocity[:, 1])))


def _hold_for(rho1: float, rho2: float, duration: float, params: Class2Params,
              target: tuple[float, float]) -> Reference:
    """Rest at ``(rho1, rho2)`` for ``duration`` [s] (a move of zero length)."""
    h = hold_reference(rho1, rho2, params)
    n = 2
    return Reference(duration, np.repeat(h.q, n, 0), np.zeros((n, 3)), np.repeat(h.force, n, 0), params,
                     kind="end_effector", target=target)
