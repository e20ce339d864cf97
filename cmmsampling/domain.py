"""The part of a face's parameter range that lies on the face.

For an untrimmed face this is the rectangle ``bounds``; trimmed faces are classified on a raster
(see :class:`FaceDomain`). Strategies and the optimisers only ever place points where
:meth:`FaceDomain.contains` is True.
"""
import numpy as np


class FaceDomain:
    """Parameter domain of a face: the rectangle (u0, u1, v0, v1)."""

    def __init__(self, bounds):
        self.bounds = tuple(float(b) for b in bounds)

    @property
    def lower(self):
        """(2,) lower corner (u0, v0)."""
        return np.array([self.bounds[0], self.bounds[2]])

    @property
    def upper(self):
        """(2,) upper corner (u1, v1)."""
        return np.array([self.bounds[1], self.bounds[3]])

    def contains(self, uv):
        """True where uv: (..., 2) lies in the domain; returns (...,) bool."""
        uv = np.asarray(uv, dtype=float)
        return np.all((uv >= self.lower) & (uv <= self.upper), axis=-1)

    def project(self, uv):
        """Nearest point of the domain for each uv: (..., 2) -> (..., 2)."""
        return np.clip(uv, self.lower, self.upper)

    def from_unit(self, unit):
        """Map points of the unit square, (..., 2) in [0, 1]^2, onto the parameter rectangle."""
        return self.lower + np.asarray(unit, dtype=float) * (self.upper - self.lower)
