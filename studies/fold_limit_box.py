"""The fold limit over the whole accepted parameter box, at random points.

``python -m studies.fold_limit_box [--points 60] [--seed 27]`` runs the paper's fold scenario
(``paper_fold`` with the proportional input ``f_i = gain rho_i t``) at uniform random points of
spring stiffness k in [0.25, 8] N/m, damping c in [0, 0.5] N s/m, input gain in [1, 50] and
restitution in [0, 0.9], under DOP853 at rtol 1e-7, atol 1e-9, sampled at 1 kHz over 5 s, and
prints every point whose lowest actuator length is below ``-LEAK`` [m], then the count, the
lowest length over all points and the CPU time. Points come from
``numpy.random.default_rng(seed)``, so a run is reproducible.
"""

from __future__ import annotations

import argparse
import copy
import time
from typing import Final

import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from tensegrity_core.sim import compile_scene, load_scene

#: The box: (low, high) of k [N/m], c [N s/m], gain [N/(m s)], restitution [-].
BOX: Final = ((0.25, 8.0), (0.0, 0.5), (1.0, 50.0), (0.0, 0.9))
#: A length below this is a leak through the stop [m] (the integrator's atol).
LEAK: Final = 1e-9


def lowest_length(k: float, c: float, gain: float, restitution: float) -> float:
    """The lowest actuator length [m] of the fold scenario at one point of :data:`BOX`."""
    d = copy.deepcopy(load_scene("paper_fold").data)
    d["model"]["params"].update(k=k, c=c)
    d["inputs"] = {f: {"law": "proportional", "gain": gain} for f in ("f1", "f2")}
    d["effects"] = ["inertia", "springs", "damping", {"fold_limit": {"restitution": restitution}}]
    d["integrator"] = {"method": "DOP853", "rtol": 1e-7, "atol": LEAK}
    scene = load_scene(d)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    samples: list[object] = []
    model.record(state, np.linspace(0.0, scene.duration, int(1000 * scene.duration) + 1), samples)
    q: NDArray[np.float64] = model.observe(samples)["q"]
    return float(q[:, :2].min())


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=60, help="how many random points (default 60)")
    parser.add_argument("--seed", type=int, default=27, help="seed of numpy's default_rng (default 27)")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    low, high = np.array(BOX).T
    points = rng.uniform(low, high, (args.points, len(BOX)))
    start = time.process_time()
    lowest, leaks = 0.0, 0
    for k, c, gain, restitution in tqdm(points, desc="fold scenario", unit="run"):
        m = lowest_length(k, c, gain, restitution)
        lowest = min(lowest, m)
        if m < -LEAK:
            leaks += 1
            tqdm.write(f"leak: k {k!r} N/m, c {c!r} N s/m, gain {gain!r}, restitution {restitution!r}: "
                       f"lowest length {m:.3g} m")
    print(f"{leaks} of {args.points} points leak (seed {args.seed}); lowest actuator length {lowest:.3g} m; "
          f"{time.process_time() - start:.1f} s CPU")


if __name__ == "__main__":
    main()
