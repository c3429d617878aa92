"""Passes that carry light from the lights to the receivers: photons, light views, caustic maps and tiles,
splats."""
