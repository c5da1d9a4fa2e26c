"""Symbolic (sympy) derivations behind the class-2 runtime modules.

Nothing in the runtime imports this subpackage: sympy is a test/documentation
dependency only. Run ``python -m studies.derivation.derive_dynamics`` to
re-derive the equations of motion and check the closed forms of
:mod:`tensegrity_core.class2.dynamics` against them, and
``python -m studies.derivation.paper_appendix_a`` to print the
entry-by-entry comparison with the paper's Eq. (46) and Appendix A.
"""
