"""Where the points go: the strategy records, the blind and curvature layouts, PSO, the optimal
descent, the sampling problem, its worker process and sample() itself. Imports geometry and
fitting."""
