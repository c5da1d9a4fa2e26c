"""Parameters of the planar class-2 tensegrity mechanism (Ji, Li & Lin).

Member numbering and names follow the paper (Fig. 1, Eq. 36):

====  ====  =========  ==================================
 no.  name  kind       axial stiffness / damping
====  ====  =========  ==================================
  1   AB    actuator   ``ka``
  2   BC    actuator   ``ka``
  3   CD    spring     ``k3``, damping ``c3``
  4   DE    spring     ``k2``, damping ``c2``
  5   AE    strut      ``kb``
  6   BF    strut      ``kb``
  7   EF    spring     ``k1``, damping ``c1``
  8   BE    spring     ``k4``, damping ``c4``
  9   BD    strut      ``kb``
 10   CE    strut      ``kb``
====  ====  =========  ==================================

The spring-to-stiffness assignment is the one that reproduces the paper's potential
energy Eq. (9) and modified stiffness matrix Eq. (36); damping ``c_j`` belongs to the
spring of stiffness ``k_j`` (the paper's Appendix A labels them differently, see
``docs/class2.md``). Springs are linear with zero free length.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields, replace

from tensegrity_core.errors import ParameterError

#: Positive-definite parameters (must be finite and > 0).
_POSITIVE = ("L", "k1", "k2", "k3", "k4", "ka", "kb", "m")
#: Parameters that must be finite and >= 0.
_NON_NEGATIVE = ("c1", "c2", "c3", "c4")
#: Every parameter lies in [-MAGNITUDE_RANGE[1], MAGNITUDE_RANGE[1]] and every positive one at
#: least MAGNITUDE_RANGE[0] (SI units). The formulas square and multiply parameters (K^2 L^2 in the
#: IK's discriminant, sqrt(4 L^2 - s^2) in the FK, stiffness solves with kb/k ratios): outside
#: 1e-15..1e15 those products underflow to 0 or overflow, and the FK answered beta = 0 for
#: L = 1e-300 m, the IK divided by zero for k = 1e-300 N/m. Inside the range the results are
#: homogeneous in L and in the stiffnesses (tests/hard/test_class2_param_range.py).
MAGNITUDE_RANGE = (1e-15, 1e15)
#: The unit of each parameter, for messages (``k`` and ``c`` set all four springs' stiffness
#: and damping at once).
PARAM_UNITS = {"L": "m", "m": "kg", **{n: "N/m" for n in ("k", "k1", "k2", "k3", "k4", "ka", "kb")},
               **{n: "N s/m" for n in ("c", *_NON_NEGATIVE)}}


@dataclass(frozen=True)
class Class2Params:
    """Physical parameters of the mechanism, SI units.

    Attributes
    ----------
    L : strut length of AE, BF, BD, CE [m].
    k1, k2, k3, k4 : spring stiffnesses [N/m] of EF, DE, CD, BE respectively.
    ka : axial stiffness of the actuators AB, BC [N/m] (stiffness analysis only).
    kb : axial stiffness of the struts [N/m] (stiffness analysis only).
    m : mass of each strut [kg]; each is a thin rod with I = m L^2 / 12.
    c1, c2, c3, c4 : linear damping [N s/m] of the springs EF, DE, CD, BE.

    Defaults are the paper's values (Sect. 4.3 and 5.3): L = 1, k = 1, ka = 10,
    kb = 1000, m = 2, c = 0.01.
    """

    L: float = 1.0
    k1: float = 1.0
    k2: float = 1.0
    k3: float = 1.0
    k4: float = 1.0
    ka: float = 10.0
    kb: float = 1000.0
    m: float = 2.0
    c1: float = 0.01
    c2: float = 0.01
    c3: float = 0.01
    c4: float = 0.01

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ParameterError(f"parameter {f.name} must be a number, got {v!r}")
            if not math.isfinite(v):
                raise ParameterError(f"parameter {f.name} must be finite, got {v!r}")
            if f.name in _POSITIVE and v <= 0:
                raise ParameterError(f"parameter {f.name} must be > 0 {PARAM_UNITS[f.name]}, got {v!r} "
                                     f"{PARAM_UNITS[f.name]}")
            lo, hi = MAGNITUDE_RANGE
            if abs(v) > hi or (f.name in _POSITIVE and v < lo):
                unit = PARAM_UNITS[f.name]
                span = f"between {lo:g} {unit} and {hi:g} {unit}" if f.name in _POSITIVE else f"at most {hi:g} {unit}"
                raise ParameterError(f"parameter {f.name} must be {span}, got {v!r} {unit}")
            if f.name in _NON_NEGATIVE and v < 0:
                raise ParameterError(f"parameter {f.name} must be >= 0 {PARAM_UNITS[f.name]}, got {v!r} "
                                     f"{PARAM_UNITS[f.name]}")
            object.__setattr__(self, f.name, float(v))

    @property
    def inertia(self) -> float:
        """Moment of inertia of one strut about its centroid, m L^2 / 12 [kg m^2]."""
        return self.m * self.L**2 / 12.0

    def with_overrides(self, overrides: Mapping[str, float] | None = None, **kw: float) -> Class2Params:
        """A copy with some parameters changed. ``k=`` sets k1..k4, ``c=`` sets c1..c4."""
        merged = dict(overrides or {}, **kw)
        expanded: dict[str, float] = {}
        names = {f.name for f in fields(self)}
        for key, value in merged.items():
            if key == "k":
                expanded.update(k1=value, k2=value, k3=value, k4=value)
            elif key == "c":
                expanded.update(c1=value, c2=value, c3=value, c4=value)
            elif key in names:
                expanded[key] = value
            else:
                raise ParameterError(
                    f"unknown parameter {key!r}; known: {', '.join(sorted(names | {'k', 'c'}))}"
                )
        return replace(self, **expanded)

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


#: The paper's parameter set (Sect. 4.3 for ka, kb; Sect. 5.3 for the dynamics).
PAPER_PARAMS = Class2Params()
