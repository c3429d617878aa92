"""Passes after shading: resolving supersampled frames, anti-aliasing (edge, MSAA outlines, adaptive), labels."""
