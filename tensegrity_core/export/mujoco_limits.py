"""What MuJoCo's compiler cannot take, for the MJCF writers: its floors on masses and
inertias and its tolerance on poses inside a body.

MuJoCo (``mj_loadXML``) refuses a model with a moving body whose mass or principal inertia
is below ``mjMINVAL`` (:data:`MJMINVAL`), and a ``fullinertia`` whose least eigenvalue is
below ``mjEPS`` (:data:`MJEPS`). Its compiler takes an offset inside a body (a centre of
mass, a site) below :data:`FRAME_EPS` along every axis as none, putting that point at the
body's frame; :func:`frame_shift` moves the frame to a centre of mass that near, and refuses
a site that near.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.export.errors import ExportError

FloatArray = NDArray[np.float64]

#: MuJoCo's ``mjMINVAL``: it refuses a model with a moving body whose mass [kg] or principal
#: inertia [kg m^2] is below it ("mass and inertia of moving bodies must be larger than
#: mjMINVAL").
MJMINVAL = 1e-15
#: MuJoCo's tolerance on a pose within a body [m]: an inertial or site offset below it along
#: every axis is taken as none (its compiler's ``IsNullPose``: the point is put at the body's
#: frame), so a centre of mass that near its body's reference point gets the frame instead.
FRAME_EPS = 1e-6
#: MuJoCo's ``mjEPS``: it refuses a ``fullinertia`` (a rigid body's) whose least eigenvalue
#: [kg m^2] is below it ("inertia must have positive eigenvalues").
MJEPS = 1e-14
#: The relative margin kept above these bounds for a principal inertia that MuJoCo
#: computes itself (its eigenvalues round differently from numpy's).
MJMINVAL_MARGIN = 1e-9
#: Why a mass or inertia below :data:`MJMINVAL` is refused (the end of the one-line message).
MJMINVAL_WHY = (f"MuJoCo refuses a moving body whose mass or principal inertia is below its mjMINVAL, "
                f"{MJMINVAL:g} (kg, kg m^2): give it more mass or size")


def frame_shift(com: FloatArray, sites: FloatArray, what: str, scale: float) -> FloatArray:
    """Where a body's MJCF frame goes, from its reference point (the rod's centre, the body's
    node centroid) [m]: nowhere, unless its centre of mass ``com`` is off it by less than
    :data:`FRAME_EPS` along every axis, which MuJoCo would take as on it: then to the centre of
    mass. Offsets within the rounding of coordinates of size ``scale`` [m] (``64 eps scale``)
    count as none. Raises :class:`ExportError` where a site (``sites``, (k, 3) offsets from
    the reference point) would be so near the frame."""
    rounding = 64 * np.finfo(float).eps * scale
    shift = com if _near(com, rounding) else np.zeros(3)
    for offset in np.atleast_2d(sites) - shift:
        if _near(offset, rounding):
            raise ExportError(f"{what}: a node {float(np.abs(offset).max()):.3g} m from its frame (the body's "
                              f"centre or centre of mass); MuJoCo takes any offset below {FRAME_EPS:g} m in a body "
                              f"as none: draw the body larger")
    out: FloatArray = shift
    return out


def _near(offset: FloatArray, rounding: float) -> bool:
    """Above ``rounding`` and below :data:`FRAME_EPS` along every axis (MuJoCo takes it as zero)."""
    return bool(np.any(np.abs(offset) > rounding) and np.all(np.abs(offset) < FRAME_EPS))
