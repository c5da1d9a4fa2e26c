"""Studies beside the product: derivations, verification runs and the figures of the docs.

What the documentation and the tests run to derive, check and illustrate the core, and
what no user of the suite needs at run time (sympy, long closed-loop runs, plotting of
studies). Importable from the repository's root (``./run test``, ``python -m studies...``),
as ``tests`` is; not installed with the package. The core and ``tensegrity_ros`` never
import it (``tests/test_layers.py``).
"""
