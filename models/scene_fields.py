"""Field validation of scene files: each check raises :class:`SceneError` naming the file and
the field (``scenes/x.toml: pairs[2].b: ...``). Shared by :mod:`impactnet.models.scenes` and
the compound bodies' tables (:mod:`impactnet.models.compound.scene_parts`)."""
from __future__ import annotations

import math
import re
from collections.abc import Mapping

#: Scene and body names: a letter, then letters, digits, ``_`` or ``-`` (they become file
#: names and JSON keys, so no path separators or spaces).
NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_-]*")
#: Upper bound (exclusive, dimensionless) of depth_fraction: a push as deep as the shortest
#: edge is a tunnelled body, not a contact a simulator resolves.
MAX_DEPTH_FRACTION = 1.0


class SceneError(ValueError):
    """An invalid scene; ``source`` names the file, ``path`` the field, ``reason`` the fault."""

    def __init__(self, source: str, path: str, reason: str):
        self.source, self.path, self.reason = source, path, reason
        super().__init__(f"{source}: {path}: {reason}" if path else f"{source}: {reason}")


def check_keys(table, path: str, keys: tuple[set, set], source: str) -> None:
    required, optional = keys
    missing = sorted(required - set(table))
    if missing:
        where = f"{path}." if path else ""
        raise SceneError(source, path or "(top level)",
                         f"missing {', '.join(where + m for m in missing)}")
    unknown = sorted(set(table) - required - optional)
    if unknown:
        raise SceneError(source, path or "(top level)",
                         f"unknown key(s) {', '.join(map(repr, unknown))}; allowed: "
                         f"{', '.join(sorted(required | optional))}")


def table(value, path: str, keys: tuple[set, set], source: str) -> Mapping:
    if not isinstance(value, Mapping):
        raise SceneError(source, path, f"expected a table, got {type(value).__name__}")
    check_keys(value, path, keys, source)
    return value


def number(value, path: str, source: str) -> float:
    """``value`` as a finite float; an integer too large for a float (10**309) is refused
    like an infinity, and never echoed whole."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneError(source, path, f"expected a finite number, got {_shown(value)}")
    try:
        as_float = float(value)
    except OverflowError:
        as_float = math.inf
    if not math.isfinite(as_float):
        raise SceneError(source, path, f"expected a finite number, got {_shown(value)}")
    return as_float


#: Longest text of a bad value quoted in a message (characters).
SHOWN_MAX_CHARS = 40


def _shown(value) -> str:
    """``repr(value)`` cut to :data:`SHOWN_MAX_CHARS` (a 10**309 integer has 310 digits)."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 64:
        return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
    text = repr(value)
    return text if len(text) <= SHOWN_MAX_CHARS else text[:SHOWN_MAX_CHARS] + "..."


def positive(value, path: str, source: str) -> float:
    value_m = number(value, path, source)
    if value_m <= 0:
        raise SceneError(source, path, f"must be > 0, got {value!r}")
    return value_m


def depth_range(value, path: str, source: str) -> tuple[float, float]:
    if not isinstance(value, list | tuple) or len(value) != 2:
        raise SceneError(source, path, f"expected [lo, hi], got {value!r}")
    lo, hi = (number(v, f"{path}[{i}]", source) for i, v in enumerate(value))
    if not 0.0 <= lo <= hi < MAX_DEPTH_FRACTION:
        raise SceneError(source, path, f"need 0 <= lo <= hi < {MAX_DEPTH_FRACTION:g}, "
                         f"got [{lo:g}, {hi:g}]")
    return lo, hi


def text(value, path: str, source: str) -> str:
    if not isinstance(value, str):
        raise SceneError(source, path, f"expected a string, got {value!r}")
    return value


def name(value, path: str, source: str) -> str:
    if not isinstance(value, str) or not NAME_PATTERN.fullmatch(value):
        raise SceneError(source, path, f"bad name {value!r}: a letter, then letters, "
                         "digits, '_' or '-'")
    return value
