"""One side of the two-sided deviation (cmmsampling.fitting.exact) at a set of places on the face."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass
class Side:
    """One side of the measure at K places: values (K,) signed mm; at (K, 2) the parameters on the
    substitute it depends on; directions (K, 3) unit, the gradient of the signed value with respect
    to the substitute's point there (the offset's direction times its sign)."""

    values: np.ndarray
    at: np.ndarray
    directions: np.ndarray

    @classmethod
    def zeros(cls, count: int) -> Side:
        """A Side of ``count`` entries, all zero."""
        return cls(np.zeros(count), np.zeros((count, 2)), np.zeros((count, 3)))

    def rows(self, index: Any) -> Side:
        """The Side of the entries ``index`` (an index or bool mask array)."""
        return Side(self.values[index], self.at[index], self.directions[index])

    def copy(self) -> Side:
        """A Side of copies of this Side's arrays."""
        return Side(self.values.copy(), self.at.copy(), self.directions.copy())

    def put(self, index: Any, other: Side) -> None:
        """Write other's entries into this Side's entries ``index`` (in place)."""
        self.values[index], self.at[index], self.directions[index] = other.values, other.at, other.directions

    def weighted(self, weights: np.ndarray) -> Side:
        """This Side with values and directions times ``weights`` (K,): 0 makes an entry count
        for nothing (no deviation, no gradient), 1 keeps it."""
        weights = np.asarray(weights, dtype=float)
        return Side(self.values * weights, self.at, self.directions * weights[:, None])

    def joined(self, other: Side) -> Side:
        """One Side of this Side's entries then other's."""
        return Side(np.concatenate([self.values, other.values]), np.concatenate([self.at, other.at]),
                    np.concatenate([self.directions, other.directions]))


def normals_or(normals: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """normals (M, 3), with fallback's rows (M, 3) where a normal is not finite (the face has none
    there: a collapsed edge)."""
    return np.where(np.isfinite(normals).all(1, keepdims=True), normals, fallback)
