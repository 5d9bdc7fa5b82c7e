"""Helpers that know nothing of radiosity: geometry on arrays of triangles, spatial grids, labels
of equal rows, the thread pool, progress and timing."""
