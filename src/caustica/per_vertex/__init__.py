"""Per-vertex reflection and refraction (Kakimoto et al.): the CPU side of the ``per-vertex`` technique.

``viewpoint``: least-squares virtual viewpoint, view volume, texture coordinates
(3.2-3.4, 4.2, 4.3), which hits a map hides (section 6, fig. 16); ``rays``: reflection
and double-refraction rays per vertex (3.1, 4.5); ``patches``: FOV-threshold
subdivision with shared vertices, made adaptive (4.1); ``refine``: adaptive
subdivision of a mirror's mesh (4.1, fig. 6); ``preparation``: a reflector's lens lines, view volumes, refined
mesh and texture coordinates for steps 1-3 (3.2-3.4, 4.1-4.5).
"""
from .patches import Patch, split_patches
from .rays import Refracted, double_refraction, reflection_rays, trace_lines
from .refine import Refined, Traced, refine
from .viewpoint import (Lines, ViewVolume, closest_point_to_lines, fit_view_volume, frustum_clip_from_view, hidden,
                        principal_directions, widen_view_volume)

__all__ = [
    "Lines", "Patch", "Refined", "Refracted", "Traced", "ViewVolume", "closest_point_to_lines", "double_refraction",
    "fit_view_volume", "frustum_clip_from_view", "hidden", "principal_directions", "refine", "reflection_rays",
    "split_patches", "trace_lines", "widen_view_volume",
]
