"""Errors of the bag tools."""

from __future__ import annotations

from tensegrity_core.errors import TensegrityError


class BagError(TensegrityError):
    """A bag cannot be written, read, repaired or played; the message names the path or topic."""
