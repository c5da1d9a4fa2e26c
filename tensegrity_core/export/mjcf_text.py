"""Numbers and vectors as MJCF attribute text, shared by the MJCF writers."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray


def number(x: float) -> str:
    """A float as its shortest round-trip text (MuJoCo reads it back exactly; ``inf`` as ``inf``)."""
    return repr(float(x))


def vector(v: Sequence[float] | NDArray[np.float64]) -> str:
    """Numbers separated by spaces, as MJCF writes vectors."""
    return " ".join(number(x) for x in np.asarray(v, dtype=float).ravel())
