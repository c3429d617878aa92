"""The CPU side of light, apart from GL: the light samples the shaders carry, the environment's sun, SH
irradiance and lobes, and the planning of the environment's light maps (docs/architecture.md)."""
