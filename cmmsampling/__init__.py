"""cmmsampling: where a CMM's contact probe should touch a free-form face.

Scripting API (FreeCAD Python console, ``freecadcmd`` or ``/usr/bin/python3``)::

    import cmmsampling
    face = cmmsampling.reference_face()            # or obj.Shape.Faces[0]
    result = cmmsampling.sample(face, n=81, strategy="pso")
    result.points, result.normals, result.uv       # (N, 3) mm, (N, 3), (N, 2)
    result.deviation.maximum                       # mm
    result.substitute                              # Part.BSplineSurface
    sorted(cmmsampling.STRATEGIES)

The method follows Zahmati & Amirabadi, Modares Mechanical Engineering 16(8), 55-64, 2016.
"""
from .freecad_env import import_part

import_part()

from .fitting import default_pole_count  # noqa: E402
from .result import SamplingResult  # noqa: E402
from .sampling import STRATEGIES, evaluate, sample  # noqa: E402
from .surface import SurfaceModel, reference_face  # noqa: E402

__all__ = [
    "STRATEGIES", "SamplingResult", "SurfaceModel", "default_pole_count", "evaluate",
    "reference_face", "sample",
]
