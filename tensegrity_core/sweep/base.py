"""The base of a sweep: a scene or a structure, read once into a plain document.

Key paths apply to this document (plain dicts and lists, as parsed from the file), and each
point's copy goes through the core's own loaders (``load_scene(dict)``,
``load_structure(dict)``), which check it. Everything a loader would read from another file
is made self-contained here, on the machine that reads the sweep file, so workers need no
files and a document means the same wherever it is loaded:

- a general scene's ``model.structure`` (a file next to the scene or a shipped example) is
  inlined as its parsed description, so ``model.structure.members[...]`` key paths reach it;
- a ``series`` input's CSV ``file`` becomes an absolute path (the workers of an external
  cluster must then see the same file system).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

BASE_KINDS = ("scene", "structure")


class BaseError(ValueError):
    """The base cannot be found or parsed."""


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


def plain(value: Any) -> Any:
    """Parsed YAML (mappings and lists that remember their lines) as plain dicts and lists."""
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v) for v in value]
    return value


def parse_file(path: Path) -> dict[str, Any]:
    """A YAML or TOML file as a plain dict (the parser the core's loaders use)."""
    from tensegrity_core.schema import SchemaError, parse_text

    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        raise BaseError(f"cannot read {str(path)!r}: {err.strerror}") from None
    try:
        data = parse_text(text, "toml" if path.suffix.lower() == ".toml" else "yaml")
    except SchemaError as err:
        raise BaseError(f"{path.name}: {err}") from None
    document: dict[str, Any] = plain(data)
    return document


def _find(value: str, folder: Path, names: Callable[[], list[str]], shipped_path: Callable[[str], Path],
          what: str) -> Path:
    candidate = folder / value
    if candidate.is_file():
        return candidate
    if value in names():
        return shipped_path(value)
    from tensegrity_core.schema import suggest

    raise BaseError(f"no {what} file {str(candidate)!r} and no shipped {what} {value!r}"
                    f"{suggest(value, names())}; shipped: {', '.join(names())}")


def load_base(kind: str, value: str, folder: Path) -> Base:
    """Read the base ``kind`` ("scene" or "structure") named ``value``: a file relative to
    ``folder`` (the sweep file's folder) or a shipped scene / example structure."""
    if not isinstance(value, str) or not value.strip():
        raise BaseError(f"must name a shipped {kind} or a file, got {value!r}")
    if kind == "scene":
        from tensegrity_core.sim import scene_names, scene_path

        path = _find(value, folder, scene_names, scene_path, "scene")
        document = parse_file(path)
        _inline_files(document, path.parent)
    else:
        from tensegrity_core.general import example_names, example_path

        path = _find(value, folder, example_names, example_path, "structure")
        document = parse_file(path)
        document.setdefault("name", path.stem)
    return Base(kind, value, str(path), document)


def _inline_files(scene: dict[str, Any], folder: Path) -> None:
    """Make a scene document self-contained (see the module docstring)."""
    model = scene.get("model")
    if isinstance(model, dict) and model.get("kind") == "general" and isinstance(model.get("structure"), str):
        from tensegrity_core.general import example_names, example_path

        path = _find(model["structure"], folder, example_names, example_path, "structure")
        structure = parse_file(path)
        structure.setdefault("name", path.stem)
        model["structure"] = structure
    inputs = scene.get("inputs")
    if isinstance(inputs, dict):
        for law in inputs.values():
            if isinstance(law, dict) and law.get("law") == "series" and isinstance(law.get("file"), str):
                law["file"] = str((folder / law["file"]).resolve())
