"""The substitute geometry: the least-squares B-spline space, the batched fit, the geometric
deviation, the lower bound and OCC's cross-check. Imports geometry only."""
