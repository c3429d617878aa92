"""Passes that shade what the camera sees: surfaces, deferred resolves, shadow maps, the environment's lobes and
light maps, and the refractors' exit helpers (d_N, convex exits, glass contact)."""
