"""Fixtures of the sweep tests: small sweeps, and no process left behind.

Every test module here checks at its end that the processes it started (Dask schedulers,
workers, CLI subprocesses) are gone; any that are left are killed by their pid and the
module fails, so a leak shows instead of slowing down the rest of the suite.
"""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


def _resource_tracker(process) -> bool:
    """multiprocessing's helper, started once for this interpreter and ended with it."""
    try:
        return "multiprocessing.resource_tracker" in " ".join(process.cmdline())
    except Exception:  # noqa: BLE001 - gone already
        return True


@pytest.fixture(autouse=True, scope="module")
def _no_process_left_behind():
    psutil = pytest.importorskip("psutil")
    me = psutil.Process()
    before = {p.pid for p in me.children(recursive=True)}
    yield
    left = [p for p in me.children(recursive=True) if p.pid not in before and not _resource_tracker(p)]
    gone, alive = psutil.wait_procs(left, timeout=15)
    names = []
    for p in alive:
        try:
            names.append((p.pid, " ".join(p.cmdline())[:120]))
            p.kill()
        except psutil.NoSuchProcess:
            pass
    psutil.wait_procs(alive, timeout=5)
    assert not names, f"processes left behind: {names}"


def fold_sweep(**changes) -> dict:
    """A small sweep of the paper's fold (1.6 s, past the first fold at 1.38 s)."""
    sweep = {
        "name": "small_fold",
        "base": {"scene": "paper_fold"},
        "vary": {"inputs.f1.gain": {"values": [8.0, 10.0, 12.0]}},
        "compute": {"simulate": {"duration": 1.6}},
        "results": [{"first_event_time": {"kind": "fold"}}, "t_end", {"final": {"of": "q"}}],
    }
    sweep.update(changes)
    return sweep


def monte_carlo_sweep(samples: int = 8) -> dict:
    return fold_sweep(
        name="small_mc",
        vary={"model.params.k": {"normal": {"mean": 1.0, "std": 0.05}, "scale": True, "name": "k_factor"},
              "model.params.m": {"uniform": {"low": 1.8, "high": 2.2}}},
        samples=samples, seed=7)
