"""Parse each interface definition once per build, not once per rosidl generator.

``./run setup`` builds every package of msgs_spec/ with rosidl, whose six generators (type
descriptions, C, the three C type supports, Python) each run as a Python process of their own,
and each parses every ``.idl`` file of the package again with rosidl_parser's Earley grammar
(lark): ~1.5 s of CPU per pass over tensegrity_msgs' 13 interfaces, five passes of six repeated.

This folder is on ``PYTHONPATH`` while a package builds (``ensure_interface_package`` in
``run``), with ``TENSEGRITY_IDL_CACHE`` naming a folder inside that package's build folder;
Python imports this module as every process starts. In a rosidl generator it wraps
``rosidl_parser.parser.parse_idl_string``: the parsed content of an IDL text is kept in that
folder, a pickle named by the text's SHA-256, and a later generator loads it instead of parsing
the same text again. The content depends on the text alone (the build folder, cache included,
is made anew for each build, so the parser cannot change under it): the generated code is the
same byte for byte. Python's own modules (hashlib, pickle, os.replace) suffice for a cache this
small, kept for one build; every other process is left as it is.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import sys
from pathlib import Path
from typing import Any

#: The environment variable naming the cache folder; without it nothing is changed.
CACHE_VARIABLE = "TENSEGRITY_IDL_CACHE"


def _cached(parse: Any, folder: Path) -> Any:
    """``parse`` (``parse_idl_string``) answered from ``folder`` where it parsed the same text before."""

    def parse_idl_string(idl_string: str, png_file: Any = None) -> Any:
        if png_file:                                 # the parse tree drawn too: not cached
            return parse(idl_string, png_file=png_file)
        entry = folder / (hashlib.sha256(idl_string.encode("utf-8")).hexdigest() + ".pickle")
        try:
            return pickle.loads(entry.read_bytes())
        except (OSError, pickle.UnpicklingError, EOFError):
            pass
        content = parse(idl_string)
        folder.mkdir(parents=True, exist_ok=True)
        partial = entry.with_suffix(f".{os.getpid()}")   # written whole, then renamed: a
        partial.write_bytes(pickle.dumps(content))        # generator running at once reads
        os.replace(partial, entry)                         # the old state or the new, never half
        return content

    return parse_idl_string


def _install() -> None:
    folder = os.environ.get(CACHE_VARIABLE)
    if not folder or not Path(sys.argv[0]).name.startswith("rosidl_"):
        return
    from rosidl_parser import parser

    parser.parse_idl_string = _cached(parser.parse_idl_string, Path(folder))


_install()
