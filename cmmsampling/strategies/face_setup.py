"""What sampling one face needs whatever N and strategy, built once inside a :func:`reused` block.

A tolerance search runs sample() on one face at many N, a study at several strategies, a plan
asks the face's probe edge offset first: the face's SurfaceModel and its FaceDomain (the trim
raster and the edge distances, a k-d tree query over the raster that took 0.3 s a run on a bicubic
patch) come out the same every time. Inside ``with reused():`` :func:`setup_of` hands out one
FaceSetup per face object for the whole block; outside one, every call builds its own, so a face
changed between two calls is never served from an older build.
"""
from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator
from typing import TYPE_CHECKING

import numpy as np

from ..geometry.domain import face_domain
from ..geometry.surface import SurfaceModel, as_face

if TYPE_CHECKING:   # FreeCAD ships no type stubs: to the type checker Part's classes are Any
    import Part

    from ..access.reach import Reachability
    from ..geometry.domain import FaceDomain

_SETUPS: contextvars.ContextVar[dict[int, tuple[Part.Face, FaceSetup]] | None] = contextvars.ContextVar(
    "cmmsampling_face_setups", default=None)


class FaceSetup:
    """A face's SurfaceModel (``model``) and its FaceDomains, each built on first use.

    face: a Part.Face (or a Shape holding one face), which must not change while this is used.
    """

    def __init__(self, face: Part.Face) -> None:
        self.face = as_face(face)
        self.model = SurfaceModel.from_face(self.face)
        self._domains: dict[tuple[float, int, bytes | None], tuple[Reachability | None, FaceDomain]] = {}

    def domain(self, edge_offset: float = 0.0, reachable: Reachability | None = None,
               out_of_reach: np.ndarray | None = None) -> FaceDomain:
        """The FaceDomain keeping ``edge_offset`` mm from the edges, and (reachable: None or a
        Reachability; or out_of_reach: (K, 4) rectangles an earlier domain found out of reach)
        out of what the probe cannot reach; see :func:`cmmsampling.geometry.domain.face_domain`."""
        rectangles = None if out_of_reach is None else np.asarray(out_of_reach, dtype=float).reshape(-1, 4)
        key = (float(edge_offset), id(reachable), None if rectangles is None else rectangles.tobytes())
        if key not in self._domains:
            self._domains[key] = (reachable, face_domain(self.model, edge_offset, reachable, rectangles))
        return self._domains[key][1]


@contextlib.contextmanager
def reused() -> Iterator[None]:
    """Within the block, :func:`setup_of` builds one FaceSetup per face object and hands it out
    again (a block inside another shares the outer one's)."""
    if _SETUPS.get() is not None:
        yield
        return
    token = _SETUPS.set({})
    try:
        yield
    finally:
        _SETUPS.reset(token)


def setup_of(face: Part.Face) -> FaceSetup:
    """The FaceSetup of a face: the one built earlier in the current :func:`reused` block for
    this very face object, else a new one (kept for the rest of the block)."""
    setups = _SETUPS.get()
    if setups is None:
        return FaceSetup(face)
    held = setups.get(id(face))
    if held is None:
        held = setups[id(face)] = (face, FaceSetup(face))
    return held[1]
