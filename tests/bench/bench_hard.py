"""Benchmarks of the issue-9 fixes (``--only hard``), each against its baseline in the same run.

(Structure loading, once ``yaml_load`` here, has its own group: ``--only load``.)
- ``slack_newton``: form-finding of the C spine drawn straight (strings go slack in the
  first steps) with the slack-string Newton matrix against the exact K_T throughout
  (quick: 40 vertebrae, where the exact K_T still takes ~4x the slack matrix's iterations;
  full: 100 and 300).
- ``unbalanced``: the unsupported table with a net load: the upfront check against the
  200 Newton iterations it took before.
"""

from __future__ import annotations

import time

from tests.bench.harness import Context, Row, benchmark


def _timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


@benchmark
def slack_newton(ctx: Context) -> list[Row]:
    from tensegrity_core.general import form_find, tensegrity_spine

    rows = []
    for n in ([40] if ctx.quick else [100, 300]):
        s = tensegrity_spine(n, shape="C")
        exact, t_exact = _timed(lambda s=s: form_find(s, slack_stiffness=False, max_iter=400))
        slack, t_slack = _timed(lambda s=s: form_find(s, max_iter=400))
        assert exact.success and slack.success
        rows += [Row("hard", f"exact K_T Newton, C spine {n}", t_exact, "s", note=f"{exact.iterations} it"),
                 Row("hard", f"slack-string Newton matrix, C spine {n}", t_slack, "s",
                     baseline=f"exact K_T Newton, C spine {n}", note=f"{slack.iterations} it")]
    return rows


@benchmark
def unbalanced(ctx: Context) -> list[Row]:
    from tensegrity_core.general import example_path, form_find, load_structure
    from tensegrity_core.general.formfind import DEFAULT_TOLERANCE, newton
    from tensegrity_core.general.statics import as_configuration

    s = load_structure(example_path("tensegrity_table").read_text() + "loads: {c1: [0, 0, -10]}\n")
    old, t_old = _timed(lambda: newton(s, as_configuration(s, None), tol=DEFAULT_TOLERANCE, max_iter=200))
    new, t_new = _timed(lambda: form_find(s))
    assert not old.success and new.status == 7
    return [Row("hard", "Newton iterating on an unbalanced load", t_old, "s", note=f"{old.iterations} it"),
            Row("hard", "form_find with the upfront check", t_new, "s",
                baseline="Newton iterating on an unbalanced load", note="0 it, says why")]
