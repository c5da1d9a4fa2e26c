"""Errors of the exporters."""

from __future__ import annotations

from tensegrity_core.errors import TensegrityError


class ExportError(TensegrityError, ValueError):
    """What was asked cannot be exported (a class-2 scene, a quasi-static scene, a bad option);
    the message says why in one line."""
