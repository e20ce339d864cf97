"""The face as the numerics see it: B-spline and NURBS bases, the surface model over OCC, the
trimmed parameter domain and the FreeCAD import shim. Imports nothing else of the package."""
