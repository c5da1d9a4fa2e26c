"""The base of a sweep: a scene or a structure, read once into a plain document.

Key paths apply to this document (plain dicts and lists, as parsed from the file), and each
point's copy goes through the core's own loaders (``load_scene(dict)``,
``load_structure(dict)``), which check it. A scene's references to other files are
resolved here, on the machine that reads the sweep file
(:func:`~tensegrity_core.sim.scene.references.self_contained`), so workers need no files and
a document means the same wherever it is loaded.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tensegrity_core.schema import excerpt, plain, read_file, resolve_source
from tensegrity_core.sweep.errors import SweepError

BASE_KINDS = ("scene", "structure")


@dataclass(frozen=True)
class Base:
    """``kind`` "scene" or "structure"; ``source`` as the sweep file named it; ``path`` the
    file read; ``document`` the parsed, self-contained document (normalised once while the
    sweep is read: an effect that a key path selects gets its options mapping, the same
    effect; never changed afterwards)."""

    kind: str
    source: str
    path: str
    document: dict[str, Any]

    @property
    def model_kind(self) -> object:
        """A scene's ``model.kind`` as the document gives it (``class2`` / ``general`` in a valid
        scene), else None."""
        model = self.document.get("model") if self.kind == "scene" else None
        return model.get("kind") if isinstance(model, dict) else None


def load_base(kind: str, value: object, folder: Path) -> Base:
    """Read the base ``kind`` ("scene" or "structure") named ``value``: a file relative to
    ``folder`` (the sweep file's folder) or a shipped scene / example structure. Raises
    :class:`SweepError` for a name or file that is not there, the format's own error
    (``SceneError``, ``StructureError``) for a file that cannot be read."""
    if not isinstance(value, str) or not value.strip():
        raise SweepError(f"must name a shipped {kind} or a file, got {excerpt(value)}")
    if kind == "scene":
        from tensegrity_core.sim.errors import SceneError
        from tensegrity_core.sim.scene.reader import SHIPPED_SCENES
        from tensegrity_core.sim.scene.references import self_contained

        path = _path(resolve_source(value, what="scene", shipped=SHIPPED_SCENES, error=SweepError,
                                    folder=folder, text=None, data=False).path)
        document = _mapping(read_file(path, error=SceneError, fmt="yaml", what="scene file")[0], "scene", path)
        document = self_contained(document, path.parent)
    else:
        from tensegrity_core.general.examples import SHIPPED_EXAMPLES
        from tensegrity_core.general.loading import SUFFIXES
        from tensegrity_core.general.structure import StructureError

        path = _path(resolve_source(value, what="structure", shipped=SHIPPED_EXAMPLES, error=SweepError,
                                    suffixes=SUFFIXES, folder=folder, text=None, data=False).path)
        document = _mapping(plain(read_file(path, error=StructureError, what="structure file")[0]), "structure",
                            path)
        document.setdefault("name", path.stem)
    return Base(kind, value, str(path), document)


def _path(path: Path | None) -> Path:
    assert path is not None               # resolve_source gives a path when text and data are refused
    return path


def _mapping(data: object, kind: str, path: Path) -> dict[str, Any]:
    if not isinstance(data, dict):
        raise SweepError(f"{path.name}: a {kind} must be a mapping, got {excerpt(data)}")
    return data
