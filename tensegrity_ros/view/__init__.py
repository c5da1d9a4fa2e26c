"""The live 3D view in the browser (``tensegrity view``): frames, their sources, the page.

Needs the ``view`` extra (viser); nothing in ``tensegrity_core`` imports it. docs/view.md.
"""
