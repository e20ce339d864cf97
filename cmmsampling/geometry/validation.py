"""Checks of user input that fail early with a message naming the problem and the fix.

Refused input raises :class:`InputError` (a ValueError) or, for a value of the wrong kind,
:class:`InputTypeError` (also a TypeError): the panels and the command line show its message in
one line, and treat any other exception as a fault with its traceback.
"""
from __future__ import annotations

import numbers
from collections.abc import Sequence
from typing import Any, cast

import numpy as np


class InputError(ValueError):
    """Input the project refuses: a value, face, file or path; the message names it and what to do."""


class InputTypeError(InputError, TypeError):
    """Input of the wrong kind (e.g. a solid where a face is expected); the message says what to give."""


def check_int(name: str, value: Any, minimum: int) -> int:
    """Return value as int (16.0 counts as 16); TypeError if it is not a whole number (True is none),
    ValueError if below minimum."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        if not isinstance(value, bool) and isinstance(value, numbers.Real) and float(value).is_integer():
            value = int(value)
        else:
            raise InputTypeError(f"{name} must be a whole number, got {value!r} ({type(value).__name__})")
    if value < minimum:
        raise InputError(f"{name} must be at least {minimum}, got {value}")
    return int(value)


def check_real(name: str, value: Any, minimum: float | None = None, maximum: float | None = None,
               above: float | None = None) -> float:
    """Return value as float; TypeError if not a number, ValueError if NaN, infinite or out of range.

    minimum/maximum are inclusive limits, above an exclusive lower limit.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputTypeError(f"{name} must be a number, got {value!r} ({type(value).__name__})")
    value = float(value)
    if not np.isfinite(value):
        raise InputError(f"{name} must be a finite number, got {value}")
    if minimum is not None and value < minimum:
        raise InputError(f"{name} must be at least {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise InputError(f"{name} must be at most {maximum}, got {value}")
    if above is not None and value <= above:
        raise InputError(f"{name} must be greater than {above}, got {value}")
    return value


def check_pair(name: str, value: Any, minimum: int) -> tuple[int, int]:
    """An int or a pair of ints, each at least minimum -> (a, b)."""
    if np.ndim(value) == 0:
        value = check_int(name, value, minimum)
        return (value, value)
    pair = tuple(value)
    if len(pair) != 2:
        raise InputError(f"{name} must be one whole number or a pair (along u, along v), got {value!r}")
    return cast("tuple[int, int]", tuple(check_int(f"{name}[{i}]", v, minimum) for i, v in enumerate(pair)))


def check_choice(name: str, value: Any, choices: Sequence[Any]) -> Any:
    """value must be one of choices; ValueError listing them otherwise."""
    if value not in choices:
        known = ", ".join(repr(c) for c in choices)
        raise InputError(f"unknown {name} {value!r}; choose one of {known}")
    return value


def check_uv(uv: Any, n: int | None = None) -> np.ndarray:
    """(N, 2) finite float array; ValueError naming the bad shape or values."""
    array = np.asarray(uv, dtype=float)
    if array.ndim != 2 or array.shape[1] != 2:
        raise InputError(f"uv must be an (N, 2) array of (u, v) pairs, got shape {array.shape}")
    if n is not None and len(array) != n:
        raise InputError(f"expected {n} (u, v) pairs, got {len(array)}")
    if not np.all(np.isfinite(array)):
        raise InputError("uv contains NaN or infinite values")
    return array
