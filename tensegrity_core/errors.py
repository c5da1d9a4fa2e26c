"""Exception hierarchy of tensegrity_core.

Every error the core raises on purpose derives from :class:`TensegrityError`, so callers
(the CLI, the ROS nodes) can catch one class and show its message. Messages name the
offending input and its value; errors about singular sets say how close the input is.
"""

from __future__ import annotations


class TensegrityError(Exception):
    """Base class of every deliberate error of tensegrity_core."""


class ParameterError(TensegrityError, ValueError):
    """A model parameter is missing, non-finite or outside its physical range."""


class DomainError(TensegrityError, ValueError):
    """An input lies outside the domain where the requested quantity exists.

    ``distance`` is how far outside the domain the input is (same units as the input,
    ``nan`` when not meaningful).
    """

    def __init__(self, message: str, *, distance: float = float("nan")):
        super().__init__(message)
        self.distance = distance


class SingularityError(TensegrityError, ArithmeticError):
    """The input is on (or numerically too close to) a singular set.

    ``kind`` names the singular set (e.g. ``"lambda1"``), ``distance`` is the distance to
    it and ``limit`` the distance below which the computation refuses to answer.
    """

    def __init__(self, message: str, *, kind: str, distance: float, limit: float = 0.0):
        super().__init__(message)
        self.kind = kind
        self.distance = distance
        self.limit = limit


class ConvergenceError(TensegrityError, RuntimeError):
    """An iterative method did not reach its tolerance; ``result`` holds the last iterate."""

    def __init__(self, message: str, *, result: object = None):
        super().__init__(message)
        self.result = result


def interrupted(err: BaseException | None) -> bool:
    """Whether a Ctrl-C (``KeyboardInterrupt``) is in the chain of ``err`` (its causes, or
    else its contexts): an interrupt that a library turned into an error of its own, which
    must end the work as the Ctrl-C it was, not be reported as a failure. pybind11 modules
    (matplotlib's, MuJoCo's) raise ``ImportError("initialization failed")`` from the
    ``KeyboardInterrupt`` of a Ctrl-C that lands while they are imported."""
    seen: set[int] = set()
    while err is not None and id(err) not in seen:
        if isinstance(err, KeyboardInterrupt):
            return True
        seen.add(id(err))
        err = err.__cause__ or err.__context__
    return False
