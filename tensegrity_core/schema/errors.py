"""The one error class of every description format, and the pieces its messages are made of.

:class:`SchemaError` carries where the problem is: ``key`` (the key path, e.g.
``("effects", 2, "fold_limit")``), ``line`` (1-based, when the text had lines) and ``file``
(the file's name, when there was a file). Each format subclasses it
(:class:`~tensegrity_core.sim.errors.SceneError`,
:class:`~tensegrity_core.general.structure.StructureError`), so callers catch the format's
class or this one. Messages quote offending values through :func:`excerpt`, which never
renders more than a short, bounded piece of a value, however large or deep the value is,
and name places by key path (:func:`format_key_path`).
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Iterable
from typing import Any, ClassVar, Final, Self, TypeAlias

from tensegrity_core.errors import TensegrityError
from tensegrity_core.excerpt import clip, excerpt

__all__ = ["KeyPath", "SchemaError", "clip", "described", "excerpt", "format_key_path", "suggest",
           "type_name"]   # excerpt, clip: the core's one helper

#: Where a value sits in a nested description: mapping keys (str, or any scalar key a
#: document may have) and list positions (int), outermost first.
KeyPath: TypeAlias = tuple[object, ...]


#: Longest key written whole in a key path [characters]; a longer one (a hostile document's)
#: is cut (:func:`clip`), so that a message naming it stays one short line.
KEY_LIMIT: Final = 60


def format_key_path(path: KeyPath) -> str:
    """``("effects", 2, "fold_limit")`` -> ``"effects[2].fold_limit"``; a key longer than
    :data:`KEY_LIMIT` characters is cut."""
    out = ""
    for part in path:
        if isinstance(part, int) and not isinstance(part, bool):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + clip(part, KEY_LIMIT)
    return out


class SchemaError(TensegrityError, ValueError):
    """A description is invalid.

    ``reason`` is the message without location, ``key`` the key path (tuple of str and
    int), ``line`` the 1-based line or ``None``, ``file`` the file name or ``None``.
    ``str(err)`` reads ``file: key.path: reason (line N)`` with the parts that are known.
    """

    #: Whether ``str()`` starts with the key path. Formats whose reasons name the entry in
    #: words (``member 's3': ...``) turn it off; ``key`` is set either way.
    show_key: ClassVar[bool] = True

    def __init__(self, reason: str, *, key: KeyPath = (), line: int | None = None,
                 file: str | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.key = tuple(key)
        self.line = line
        self.file = file

    def __str__(self) -> str:
        text = self.reason
        if self.show_key and self.key:
            text = f"{format_key_path(self.key)}: {text}"
        if self.line is not None:
            text += f" (line {self.line})"
        if self.file:
            text = f"{self.file}: {text}"
        return text

    def located(self, *, line: int | None = None, file: str | None = None) -> Self:
        """The same error (same class) with ``line`` and ``file`` filled in where unknown."""
        err = type(self).__new__(type(self))
        SchemaError.__init__(err, self.reason, key=self.key, line=self.line if self.line is not None else line,
                             file=self.file or file)
        return err

    def __reduce__(self) -> tuple[Callable[..., SchemaError], tuple[Any, ...]]:
        return _rebuild, (type(self), self.reason, self.key, self.line, self.file)


def _rebuild(cls: type[SchemaError], reason: str, key: KeyPath, line: int | None, file: str | None) -> SchemaError:
    err = cls.__new__(cls)
    SchemaError.__init__(err, reason, key=key, line=line, file=file)
    return err


def type_name(value: Any) -> str:
    """``"a number"``, ``"a string"``, ... : what a value is, in words."""
    for kind, name in ((bool, "a boolean"), (dict, "a mapping"), (list, "a list"), (str, "a string"),
                       (int, "an integer"), (float, "a number"), (type(None), "nothing (null)")):
        if isinstance(value, kind):
            return name
    return type(value).__name__


def described(value: Any) -> str:
    """What a value is and, unless it is null, an excerpt of it: ``"a string ('1.0 s')"``,
    ``"nothing (null)"`` (an empty file or a key with no value)."""
    if value is None:
        return type_name(value)
    return f"{type_name(value)} ({excerpt(value)})"


#: Suggestions are searched among at most this many choices of similar length (difflib
#: compares every candidate; a 100,000-name structure would make an error take seconds).
_MAX_SUGGESTION_CANDIDATES: Final = 2_000
_MAX_SUGGESTION_WORD: Final = 100


def suggest(word: object, choices: Iterable[object], template: str = " (did you mean {!r}?)") -> str:
    """``template`` filled with the closest of ``choices`` to ``word`` (difflib), or ``""``."""
    word = str(word)
    if len(word) > _MAX_SUGGESTION_WORD:
        return ""
    names = [str(c) for c in choices]
    if len(names) > _MAX_SUGGESTION_CANDIDATES:
        names = [c for c in names if abs(len(c) - len(word)) <= 2][:_MAX_SUGGESTION_CANDIDATES]
    close = difflib.get_close_matches(word, names, n=1)
    return template.format(close[0]) if close else ""
