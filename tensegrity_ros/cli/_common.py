"""Helpers shared by the CLI subcommands: one-line errors, JSON output, parameters, listings."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from typing import Any, TypeAlias

from tensegrity_core.errors import TensegrityError

#: What a command module's ``register`` adds its subcommands to.
Subparsers: TypeAlias = "argparse._SubParsersAction[argparse.ArgumentParser]"
#: A subcommand's handler: the parsed arguments to the process exit code.
Handler: TypeAlias = Callable[[argparse.Namespace], int]


class CliError(TensegrityError):
    """A user-facing failure: printed as one ``error:`` line, exit code ``code``."""

    def __init__(self, message: str, code: int = 2) -> None:
        super().__init__(message)
        self.code = code


def fail(message: str, code: int = 2) -> int:
    print(f"error: {message}", file=sys.stderr)
    return code


def _jsonable(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        return _jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None if math.isnan(obj) else ("inf" if obj > 0 else "-inf")
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    return obj


def check_seconds(value: float, option: str, *, zero: str | None = None) -> None:
    """Refuse a time option that is not a finite number of seconds > 0, or >= 0 when ``zero``
    says what 0 means (a CliError, exit 2)."""
    if math.isfinite(value) and (value > 0 or (zero is not None and value == 0)):
        return
    accepted = f">= 0 (0 = {zero})" if zero is not None else "> 0"
    raise CliError(f"{option} must be a finite number of seconds {accepted}, got {value:g}")


def check_count(value: int, option: str, lo: int, hi: int) -> None:
    """Refuse a whole-number option outside [lo, hi] (a CliError, exit 2)."""
    if not lo <= value <= hi:
        raise CliError(f"{option} must be a whole number in [{lo}, {hi}], got {value}")


def print_json(data: Any) -> None:
    """Print ``data`` as JSON (numpy arrays become lists, NaN becomes null)."""
    json.dump(_jsonable(data), sys.stdout, indent=2)
    sys.stdout.write("\n")


def parse_param_overrides(items: list[str] | None) -> dict[str, float]:
    """Parse repeated ``--param NAME=VALUE`` options into a dict of floats."""
    out: dict[str, float] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise CliError(f"--param expects NAME=VALUE, got {item!r}")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise CliError(f"--param {name.strip()}: {value!r} is not a number") from None
    return out


def add_json_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="machine-readable JSON output")


#: A row of a listing: ``name`` and ``description`` first, then what the listing adds.
Row = dict[str, Any]


def add_listing(subparsers: Subparsers, name: str, *, help: str, description: str, rows: Callable[[], list[Row]],
                details: Callable[[Row], str]) -> None:
    """Add the subcommand ``name`` that lists what the package ships (scenes, sweeps): each
    row of ``rows()`` as its name and description, ``details(row)`` on the line below; with
    ``--json`` the rows themselves."""
    def run(args: argparse.Namespace) -> int:
        listed = rows()
        if args.json:
            print_json(listed)
            return 0
        width = max(len(r["name"]) for r in listed)
        for r in listed:
            print(f"{r['name']:<{width}}  {r['description']}")
            print(f"{'':<{width}}  {details(r)}")
        return 0

    p = subparsers.add_parser(name, help=help, description=description)
    add_json_flag(p)
    p.set_defaults(func=run)
