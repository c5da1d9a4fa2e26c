"""What a bag says about itself, taken as data from elsewhere: its YAML and its file names.

A bag folder may come from anywhere (a download, a colleague, a crashed recorder), so the
bag tools never trust what it names:

- :func:`load_bag_yaml` parses the YAML a bag carries (``metadata.yaml``, the QoS profiles in
  the MCAP channel metadata): bounded in size, UTF-8 only, the safe loader only (no Python
  objects); every failure is a :class:`BagError` whose message quotes at most an excerpt.
- :func:`path_inside` resolves a file name the bag gives (an entry of ``metadata.yaml``,
  a ``*.mcap`` found in the folder) inside the bag folder: an absolute path, a ``..`` that
  leaves the folder or a symbolic link that points out of it is refused, so reading,
  repairing or playing a bag never opens, renames, deletes or writes a file elsewhere.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any, BinaryIO

from tensegrity_core.excerpt import excerpt
from tensegrity_core.schema import Limits, SchemaError, parse_yaml
from tensegrity_ros.bag.errors import BagError

#: Largest YAML text taken from a bag [bytes]. rosbag2 metadata is about 1 kB per topic;
#: 4 MiB holds thousands of topics and files.
MAX_YAML_BYTES = 4 * 1024 * 1024


def load_bag_yaml(data: bytes | str, source: str) -> Any:
    """Parse YAML text from a bag (``source`` names it in messages), or :class:`BagError`.

    The size bound comes first, then UTF-8 decoding, then the core's bounded YAML reader
    (:func:`tensegrity_core.schema.parse_yaml`: nesting depth, aliases and the values they
    add are bounded while parsing, so a small metadata.yaml cannot expand to gigabytes).
    """
    size = len(data.encode("utf-8") if isinstance(data, str) else data)
    if size > MAX_YAML_BYTES:
        raise BagError(f"{source} is larger than the {MAX_YAML_BYTES} bytes accepted for "
                       "bag metadata")
    if isinstance(data, bytes):
        try:
            data = data.decode("utf-8")
        except UnicodeDecodeError as err:
            raise BagError(f"{source} is not UTF-8 text (byte {err.start} is "
                           f"{excerpt(data[err.start:err.start + 1])})") from None
    try:
        return parse_yaml(data, limits=Limits(max_bytes=MAX_YAML_BYTES))
    except SchemaError as err:
        at = f" at line {err.line}" if err.line is not None else ""
        raise BagError(f"{source} is not valid YAML{at}: {err.reason}") from None


def path_inside(folder: str | os.PathLike[str], name: Any, what: str = "file") -> Path:
    """``folder / name`` if it stays inside ``folder`` once every link is followed, else
    :class:`BagError`. ``name`` is a relative path as a bag names its files (a string);
    the returned path is ``folder / name`` (not resolved, so messages show what the bag
    says). The file itself need not exist.
    """
    if not isinstance(name, str) or not name or "\0" in name:
        raise BagError(f"{what} {excerpt(name)} is not a file name")
    if os.path.isabs(name):
        raise BagError(f"{what} {excerpt(name)} is an absolute path; a bag names its files "
                       "relative to its folder")
    folder = Path(folder)
    root = folder.resolve()
    path = folder / name
    target = path.resolve()
    if target != root and root not in target.parents:
        link = " (through a symbolic link)" if ".." not in Path(name).parts else ""
        raise BagError(f"{what} {excerpt(name)} is outside the bag folder {folder}{link}")
    return path


def open_regular(path: Path, what: str = "file") -> BinaryIO:
    """Open ``path`` for reading in binary mode if it is a regular file, else
    :class:`BagError` (a FIFO or device named like a bag file would block or never end)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        raise BagError(f"{what} {path} does not exist") from None
    except OSError as err:
        raise BagError(f"cannot open {what} {path}: {err.strerror}") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise BagError(f"{what} {path} is not a regular file")
    return os.fdopen(fd, "rb")


def read_bounded(path: Path, limit: int, what: str = "file") -> bytes:
    """At most ``limit`` + 1 bytes of the regular file ``path`` (one more than ``limit``
    tells the caller the file is too large)."""
    with open_regular(path, what) as f:
        data: bytes = f.read(limit + 1)
        return data
