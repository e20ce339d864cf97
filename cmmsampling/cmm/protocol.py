"""I++ DME 1.4 commands and answers as text (the specification 1.4.3, section 6.1.4.2).

A command is a tag (five digits, 00001..99999; ``E`` and four digits for the fast queue), a space
and a method: ``00012 PtMeas(X(1.5),Y(2),Z(-3),IJK(0,0,1))``. The server answers each with lines
of the same tag: ``&`` acknowledged, ``#`` data, ``%`` done, ``!`` an error
(``Error(severity, code, "method", "text")``; :mod:`.answers` reads them). Lines end in CR LF.
Numbers have at most 16 digits.
"""
from __future__ import annotations

# The most digits of an I++ number (section 6.1.4.2).
MAX_DIGITS = 16
# Decimals of a coordinate in mm (0.1 um) and of a vector component.
COORDINATE_DECIMALS = 6
VECTOR_DECIMALS = 9
LINE_END = "\r\n"
MAX_TAG = 99999


def number(value, decimals=COORDINATE_DECIMALS):
    """A float as an I++ number: fixed point, trailing zeros cut, at most MAX_DIGITS digits."""
    text = f"{float(value):.{decimals}f}".rstrip("0").rstrip(".")
    text = "0" if text in ("-0", "") else text
    if len(text.lstrip("+-").replace(".", "")) > MAX_DIGITS:
        raise ValueError(f"{value} mm has more than {MAX_DIGITS} digits at {decimals} decimals")
    return text


def vector_text(vector):
    """'0,0,1'-style components of a unit vector."""
    return ",".join(number(component, VECTOR_DECIMALS) for component in vector)


def point_arguments(point, vector=None):
    """'X(..),Y(..),Z(..)[,IJK(..)]' of a point (3,) mm and an optional vector (3,)."""
    text = ",".join(f"{axis}({number(value)})" for axis, value in zip("XYZ", point))
    return text if vector is None else f"{text},IJK({vector_text(vector)})"


def tag_text(tag, fast=False):
    """The tag of command number tag (1..MAX_TAG): '00012', or 'E0012' on the fast queue."""
    return f"E{tag % 10000:04d}" if fast else f"{(tag - 1) % MAX_TAG + 1:05d}"
