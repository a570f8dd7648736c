"""Typed, validated access to TOML tables.

Every accessor raises :class:`~fallgen.errors.InputError` naming the file and the dotted field
path, so a malformed data file gives a one-line error instead of a traceback. Unknown keys are
errors too (a typo such as ``densty`` must not be silently ignored).
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from fallgen.errors import InputError

_MISSING: Any = object()


def load_toml(path: str | Path) -> Fields:
    """Parse a TOML file into a :class:`Fields` view; syntax errors become ``InputError``."""
    path = Path(path)
    try:
        with path.open("rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise InputError(path, "<file>", "file not found") from None
    except tomllib.TOMLDecodeError as e:
        raise InputError(path, "<syntax>", str(e)) from None
    except OSError as e:
        raise InputError(path, "<file>", e.strerror or str(e)) from None
    return Fields(data, path)


class Fields:
    """A view of one TOML table that knows which file and field path it came from."""

    def __init__(self, data: Mapping[str, Any], file: str | Path, prefix: str = "") -> None:
        if not isinstance(data, Mapping):
            raise InputError(file, prefix, f"expected a table, got {_typename(data)}")
        self.data = data
        self.file = Path(file)
        self.prefix = prefix
        self._used: set[str] = set()

    # -- basics -------------------------------------------------------------------------------
    def path(self, key: str | int) -> str:
        if isinstance(key, int):
            return f"{self.prefix}[{key}]"
        return f"{self.prefix}.{key}" if self.prefix else key

    def error(self, key: str | int, message: str) -> InputError:
        return InputError(self.file, self.path(key), message)

    def __contains__(self, key: str) -> bool:
        return key in self.data

    def keys(self) -> Iterable[str]:
        return self.data.keys()

    def raw(self, key: str, default: Any = _MISSING) -> Any:
        self._used.add(key)
        if key not in self.data:
            if default is _MISSING:
                raise self.error(key, "missing required field")
            return default
        return self.data[key]

    def reject_unknown(self, allowed: Iterable[str] | None = None) -> None:
        """Raise on keys that were never read (or are not in ``allowed``)."""
        allowed_set = set(allowed) if allowed is not None else self._used
        for key in self.data:
            if key not in allowed_set:
                hint = ", ".join(sorted(allowed_set)) or "none"
                raise self.error(key, f"unknown field (allowed: {hint})")

    # -- scalars ------------------------------------------------------------------------------
    def str(self, key: str, default: Any = _MISSING, choices: Iterable[str] | None = None) -> str:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not isinstance(v, str):
            raise self.error(key, f"expected a string, got {_typename(v)}")
        if choices is not None:
            options = list(choices)
            if v not in options:
                raise self.error(key, f"{v!r} is not one of {', '.join(map(repr, options))}")
        return v

    def bool(self, key: str, default: Any = _MISSING) -> bool:
        v = self.raw(key, default)
        if not isinstance(v, bool):
            raise self.error(key, f"expected true or false, got {_typename(v)}")
        return v

    def float(
        self,
        key: str,
        default: Any = _MISSING,
        *,
        lo: float | None = None,
        hi: float | None = None,
        positive: bool = False,
    ) -> float:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        return _check_number(self, key, v, lo=lo, hi=hi, positive=positive)

    def int(
        self, key: str, default: Any = _MISSING, *, lo: int | None = None, hi: int | None = None
    ) -> int:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.error(key, f"expected an integer, got {_typename(v)}")
        if lo is not None and v < lo:
            raise self.error(key, f"must be >= {lo}, got {v}")
        if hi is not None and v > hi:
            raise self.error(key, f"must be <= {hi}, got {v}")
        return v

    def floats(
        self,
        key: str,
        default: Any = _MISSING,
        *,
        n: int | None = None,
        lo: float | None = None,
        hi: float | None = None,
        positive: bool = False,
        increasing: bool = False,
    ) -> tuple[float, ...]:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not isinstance(v, list):
            raise self.error(key, f"expected a list of numbers, got {_typename(v)}")
        if n is not None and len(v) != n:
            raise self.error(key, f"expected {n} numbers, got {len(v)}")
        out = tuple(
            _check_number(self, key, x, lo=lo, hi=hi, positive=positive, index=i)
            for i, x in enumerate(v)
        )
        if increasing and any(b < a for a, b in zip(out, out[1:])):
            raise self.error(key, f"must be non-decreasing, got {list(out)}")
        return out

    def strs(self, key: str, default: Any = _MISSING) -> tuple[str, ...]:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise self.error(key, "expected a list of strings")
        return tuple(v)

    # -- nested -------------------------------------------------------------------------------
    def table(self, key: str, default: Any = _MISSING) -> Fields:
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not isinstance(v, Mapping):
            raise self.error(key, f"expected a table, got {_typename(v)}")
        return Fields(v, self.file, self.path(key))

    def tables(self, key: str, default: Any = _MISSING) -> list[Fields]:
        """An array of tables (``[[key]]`` or a list of inline tables)."""
        v = self.raw(key, default)
        if v is default and default is not _MISSING:
            return v
        if not isinstance(v, list):
            raise self.error(key, f"expected a list of tables, got {_typename(v)}")
        out = []
        for i, item in enumerate(v):
            p = f"{self.path(key)}[{i}]"
            if not isinstance(item, Mapping):
                raise InputError(self.file, p, f"expected a table, got {_typename(item)}")
            out.append(Fields(item, self.file, p))
        return out

    def items(self) -> Iterator[tuple[str, Fields]]:
        """Sub-tables of this table, in file order (e.g. one per material)."""
        for key, v in self.data.items():
            self._used.add(key)
            if not isinstance(v, Mapping):
                raise self.error(key, f"expected a table, got {_typename(v)}")
            yield key, Fields(v, self.file, self.path(key))


def _check_number(
    f: Fields,
    key: str,
    v: Any,
    *,
    lo: float | None,
    hi: float | None,
    positive: bool,
    index: int | None = None,
) -> float:
    where = key if index is None else f"{key}[{index}]"
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise f.error(where, f"expected a number, got {_typename(v)}")
    x = float(v)
    if not math.isfinite(x):
        raise f.error(where, f"must be finite, got {x}")
    if positive and x <= 0:
        raise f.error(where, f"must be positive, got {x:g}")
    if lo is not None and x < lo:
        raise f.error(where, f"must be >= {lo:g}, got {x:g}")
    if hi is not None and x > hi:
        raise f.error(where, f"must be <= {hi:g}, got {x:g}")
    return x


def _typename(v: Any) -> str:
    return {
        dict: "a table",
        list: "a list",
        str: "a string",
        bool: "a boolean",
        int: "an integer",
        float: "a number",
    }.get(type(v), type(v).__name__)
