"""Writes pytest's assertion-rewritten code of the test modules once, before a test run
(``./run test``'s ``rewrite_test_asserts``): ``python -m tests.assertion_cache``.

pytest rewrites the ``assert`` statements of every test module and conftest it imports and
keeps the result in ``__pycache__/<name>.<tag>-pytest-<version>.pyc``, but writes it only
where Python writes byte-code: with ``PYTHONDONTWRITEBYTECODE`` set (as on shared machines)
every process that collects the suite rewrites all of them again, each of ``./run test``'s
workers ~5 s of CPU of its ~11 s of collection (measured: 10.9-11.6 s of CPU for a
collection without these files, 5.2-5.6 s with them). Here they are written with pytest's
own functions, for the files that have none or whose source changed (pytest's files carry
the source's hash, which pytest checks before it uses one); pytest reads them whatever
``PYTHONDONTWRITEBYTECODE`` says.

The rewritten code depends on one setting, ``enable_assertion_pass_hook`` (off by default,
not set in pyproject.toml: it is off here too). If pytest's functions change, this writes
nothing and says so in one line; the run goes on as before.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).absolute().parents[1]


def rewritten_modules(root: Path = ROOT) -> list[Path]:
    """The files pytest rewrites as it collects ``tests/``: the test modules (its default
    ``python_files``, ``test_*.py`` and ``*_test.py``) and the conftests."""
    tests = root / "tests"
    found = {*tests.rglob("test_*.py"), *tests.rglob("*_test.py"), *tests.rglob("conftest.py")}
    return sorted(p for p in found if "__pycache__" not in p.parts)


def write_missing(files: list[Path]) -> int:
    """Writes the rewritten code of each of ``files`` whose cache is missing or out of date;
    returns how many it wrote."""
    from _pytest.assertion.rewrite import PYC_TAIL, _read_pyc, _rewrite_test, _write_pyc

    class _NoTrace:                     # the state pytest passes only for its debug trace
        @staticmethod
        def trace(_message: str) -> None:
            pass

    written = 0
    for fn in files:
        pyc = fn.parent / "__pycache__" / (fn.name[:-3] + PYC_TAIL)
        if _read_pyc(fn, pyc) is not None:
            continue
        try:
            source_hash, code = _rewrite_test(fn, None)  # None: the default settings
        except SyntaxError:
            continue                    # pytest reports it when it collects the file
        pyc.parent.mkdir(exist_ok=True)
        written += _write_pyc(_NoTrace(), code, source_hash, pyc)
    return written


def main() -> int:
    try:
        write_missing(rewritten_modules())
    except (ImportError, TypeError, ValueError, OSError) as err:
        print(f"note: pytest's rewritten test modules were not written ahead ({err}); each test process "
              "rewrites them itself", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
