"""SurfaceModel: a face's NURBS definition, evaluated for many (u, v) at once.

Units are the document's (mm). Parameters ``uv`` are always in the face's own parameter
range, i.e. what ``face.valueAt(u, v)`` takes on :attr:`SurfaceModel.face` (for faces that had
to be converted with ``toNurbs()`` this is the converted face, whose parametrisation differs
from the original analytic one).
"""
import numpy as np

from .bspline import clamped_uniform_knots, design_matrices, full_knots
from .freecad_env import import_part

Part = import_part()
import FreeCAD  # noqa: E402  (importable once import_part() has set the path)


class SurfaceModel:
    """Poles, weights, knots and parameter range of one face, with vectorised evaluation.

    Build it with :meth:`from_face`. Attributes:
      face: the Part.Face evaluated (a B-spline face; the input itself or its ``toNurbs()``).
      source_face: the face as given.
      degrees: (k_u, k_v); poles: (n_u, n_v, 3) mm; weights: (n_u, n_v);
      uknots, vknots: full knot vectors; rational: bool;
      bounds: (u0, u1, v0, v1), the face's parameter range;
      reversed: True when the face is Reversed (normals are flipped to point out of the material).
    """

    def __init__(self, face, source_face, surface):
        self.face = face
        self.source_face = source_face
        self.degrees = (surface.UDegree, surface.VDegree)
        self.poles = np.array([[tuple(p) for p in row] for row in surface.getPoles()], dtype=float)
        self.weights = np.array(surface.getWeights(), dtype=float)
        self.uknots = full_knots(surface.getUKnots(), surface.getUMultiplicities())
        self.vknots = full_knots(surface.getVKnots(), surface.getVMultiplicities())
        self.rational = not np.allclose(self.weights, self.weights.flat[0], rtol=0, atol=1e-14)
        self.bounds = tuple(float(b) for b in face.ParameterRange)
        self.reversed = face.Orientation == "Reversed"
        self._homogeneous = np.concatenate(
            [self.poles * self.weights[..., None], self.weights[..., None]], axis=2
        )

    @classmethod
    def from_face(cls, face):
        """Model of a Part.Face: B-spline faces as they are, any other surface via ``toNurbs()``.

        Periodic B-splines are made non-periodic (same geometry, clamped knots).
        Raises TypeError for anything that is not a single face.
        """
        face = as_face(face)
        evaluated = face
        if not isinstance(face.Surface, Part.BSplineSurface):
            evaluated = face.toNurbs().Faces[0]
        surface = evaluated.Surface.copy()
        if surface.isUPeriodic():
            surface.setUNotPeriodic()
        if surface.isVPeriodic():
            surface.setVNotPeriodic()
        return cls(evaluated, face, surface)

    @property
    def span(self):
        """(du, dv): the lengths of the parameter range."""
        u0, u1, v0, v1 = self.bounds
        return (u1 - u0, v1 - v0)

    def _homogeneous_derivatives(self, uv, order):
        """Derivatives of the homogeneous surface A(u, v) = sum w P N, w(u, v) = sum w N.

        uv: (N, 2). Returns dict {(a, b): (N, 4)} for all a + b <= order.
        """
        uv = np.asarray(uv, dtype=float).reshape(-1, 2)
        bu = design_matrices(self.uknots, self.degrees[0], uv[:, 0], order)
        bv = design_matrices(self.vknots, self.degrees[1], uv[:, 1], order)
        n_u, n_v = self.weights.shape
        flat = self._homogeneous.reshape(n_u, n_v * 4)
        out = {}
        for a in range(order + 1):
            along_u = (bu[a] @ flat).reshape(-1, n_v, 4)
            for b in range(order + 1 - a):
                out[(a, b)] = np.einsum("njc,nj->nc", along_u, bv[b])
        return out

    def derivatives(self, uv, order=1):
        """Surface point and partial derivatives up to ``order`` (0, 1 or 2), rational-exact.

        uv: (N, 2) in the parameter range. Returns dict {(a, b): (N, 3)} with the a-th u- and
        b-th v-derivative, in mm per parameter unit.
        """
        h = self._homogeneous_derivatives(uv, order)
        w = {key: value[:, 3:] for key, value in h.items()}
        a = {key: value[:, :3] for key, value in h.items()}
        s = {(0, 0): a[(0, 0)] / w[(0, 0)]}
        if order >= 1:
            s[(1, 0)] = (a[(1, 0)] - w[(1, 0)] * s[(0, 0)]) / w[(0, 0)]
            s[(0, 1)] = (a[(0, 1)] - w[(0, 1)] * s[(0, 0)]) / w[(0, 0)]
        if order >= 2:
            base = s[(0, 0)]
            s[(2, 0)] = (a[(2, 0)] - 2 * w[(1, 0)] * s[(1, 0)] - w[(2, 0)] * base) / w[(0, 0)]
            s[(0, 2)] = (a[(0, 2)] - 2 * w[(0, 1)] * s[(0, 1)] - w[(0, 2)] * base) / w[(0, 0)]
            s[(1, 1)] = (
                a[(1, 1)] - w[(1, 0)] * s[(0, 1)] - w[(0, 1)] * s[(1, 0)] - w[(1, 1)] * base
            ) / w[(0, 0)]
        return s

    def points(self, uv):
        """Surface points, uv: (..., 2) -> (..., 3) mm."""
        uv = np.asarray(uv, dtype=float)
        h = self._homogeneous_derivatives(uv, 0)[(0, 0)]
        return (h[:, :3] / h[:, 3:]).reshape(uv.shape[:-1] + (3,))

    def normals(self, uv):
        """Unit normals pointing out of the material (face orientation respected).

        uv: (..., 2) -> (..., 3). Where the surface is degenerate (zero cross product) the
        normal is NaN.
        """
        uv = np.asarray(uv, dtype=float)
        d = self.derivatives(uv.reshape(-1, 2), 1)
        return unit_normals(d[(1, 0)], d[(0, 1)], self.reversed).reshape(uv.shape[:-1] + (3,))

    def curvatures(self, uv):
        """Mean and Gaussian curvature at uv: (N, 2) -> (H, K), each (N,), in 1/mm and 1/mm^2.

        The sign of H follows the outward normal.
        """
        d = self.derivatives(uv, 2)
        su, sv = d[(1, 0)], d[(0, 1)]
        n = unit_normals(su, sv, self.reversed)
        e, f, g = (su * su).sum(1), (su * sv).sum(1), (sv * sv).sum(1)
        l_, m_, n_ = (d[(2, 0)] * n).sum(1), (d[(1, 1)] * n).sum(1), (d[(0, 2)] * n).sum(1)
        det = e * g - f * f
        mean = (e * n_ - 2 * f * m_ + g * l_) / (2 * det)
        gauss = (l_ * n_ - m_ * m_) / det
        return mean, gauss

    def raster(self, size):
        """A regular raster of the parameter range: size (n_u, n_v) -> uv (n_u, n_v, 2)."""
        u0, u1, v0, v1 = self.bounds
        u = np.linspace(u0, u1, size[0])
        v = np.linspace(v0, v1, size[1])
        return np.stack(np.meshgrid(u, v, indexing="ij"), axis=-1)


def unit_normals(su, sv, reversed_face):
    """Normalised su x sv, flipped for a Reversed face. su, sv: (N, 3) -> (N, 3)."""
    n = np.cross(su, sv)
    with np.errstate(invalid="ignore", divide="ignore"):
        n = n / np.linalg.norm(n, axis=1, keepdims=True)
    return -n if reversed_face else n


def as_face(shape):
    """The single Part.Face in ``shape`` (a Face, or a Shape holding exactly one face).

    Raises TypeError naming what was given otherwise.
    """
    if isinstance(shape, Part.Face):
        return shape
    if isinstance(shape, Part.Shape):
        faces = shape.Faces
        if len(faces) == 1:
            return faces[0]
        if not faces:
            raise TypeError(
                f"expected a face, got a{'n' if shape.ShapeType[0] in 'AEIOU' else ''} "
                f"{shape.ShapeType} with no faces; select a face of a solid, shell or surface"
            )
        raise TypeError(
            f"expected one face, got a {shape.ShapeType} with {len(faces)} faces; "
            "pick a single face, e.g. shape.Faces[0]"
        )
    raise TypeError(
        f"expected a Part.Face, got {type(shape).__name__}; "
        "pass a face, e.g. obj.Shape.Faces[0] or cmmsampling.reference_face()"
    )


def reference_poles():
    """Poles of the reference surface: (9, 9, 3) mm.

    x_i = 12.5 i, y_j = 12.5 j (i, j = 0..8),
    z = 12 sin(2.5 pi x / 100) cos(1.7 pi y / 100) + 8 exp(-((x - 70)^2 + (y - 30)^2) / 300).
    """
    x, y = np.meshgrid(12.5 * np.arange(9), 12.5 * np.arange(9), indexing="ij")
    z = 12 * np.sin(2.5 * np.pi * x / 100) * np.cos(1.7 * np.pi * y / 100) + 8 * np.exp(
        -((x - 70) ** 2 + (y - 30) ** 2) / 300
    )
    return np.stack([x, y, z], axis=-1)


def make_bspline_surface(poles, degrees, weights=None, uknots=None, vknots=None):
    """A Part.BSplineSurface from poles (n_u, n_v, 3), degrees (k_u, k_v) and full knot vectors.

    Knots default to clamped uniform on [0, 1]; weights (n_u, n_v) default to 1.
    """
    poles = np.asarray(poles, dtype=float)
    n_u, n_v = poles.shape[:2]
    if uknots is None:
        uknots = clamped_uniform_knots(degrees[0], n_u)
    if vknots is None:
        vknots = clamped_uniform_knots(degrees[1], n_v)
    ku, mu = np.unique(uknots, return_counts=True)
    kv, mv = np.unique(vknots, return_counts=True)
    vectors = [[FreeCAD.Vector(*map(float, p)) for p in row] for row in poles]
    surface = Part.BSplineSurface()
    args = [vectors, mu.tolist(), mv.tolist(), ku.tolist(), kv.tolist(), False, False,
            int(degrees[0]), int(degrees[1])]
    if weights is not None:
        args.append(np.asarray(weights, dtype=float).tolist())
    surface.buildFromPolesMultsKnots(*args)
    return surface


def reference_face():
    """The built-in reference face: degree (5, 5), 9 x 9 poles over a 100 x 100 mm square.

    Clamped uniform knots, all weights 1; see :func:`reference_poles` for the pole heights.
    """
    return make_bspline_surface(reference_poles(), (5, 5)).toShape()
