"""Material look-ups for ray hits: which object indices are glass, diffuse, mirror."""
from __future__ import annotations

import numpy as np


def objects_of_kind(scene, kind: str) -> np.ndarray:
    """(K + 1,) bool, indexed by a hit's object index: True for objects whose material is ``kind``.

    The last entry (read by object index -1, a miss) is False.
    """
    return np.array([o.material.kind == kind for o in scene.objects] + [False], dtype=bool)
