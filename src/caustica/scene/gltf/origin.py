"""What a glTF file said that caustica's scene does not model, kept beside the scene so that export writes
it back: the names of materials, lights and cameras, ``doubleSided``, the extension data caustica reads but
does not render (``KHR_materials_specular``...), ``extensionsRequired`` and which ``extras.caustica`` keys
the file had. Records are keyed by the identity of the scene part they describe (the part is kept alive
here, so an id is never reused): a part the user replaces is written as caustica writes its own."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class MaterialOrigin:
    """A glTF material as the file gave it: its name, doubleSided, the extensions (name -> data) that
    export carries unchanged, and whether it is glass without KHR_materials_volume (thin-walled by the
    glTF spec; caustica renders it solid)."""

    name: str | None
    double_sided: bool
    extensions: dict
    thin_walled: bool = False


@dataclass
class LightOrigin:
    """A KHR_lights_punctual light's name and its node's name."""

    name: str | None
    node_name: str | None


@dataclass
class CameraOrigin:
    """A glTF camera's name and node name, the ``extras.caustica`` keys the file had, the size and focus
    distance caustica made of it (a key the file lacked is written only once the user changed it) and its
    ``perspective`` fields (its own aspectRatio is written back while the size is unchanged; caustica's
    whole pixels only approach it)."""

    name: str | None
    node_name: str | None
    extras_keys: frozenset
    size: tuple[int, int]
    focus_distance: float
    perspective: dict = field(default_factory=dict)


@dataclass
class NodeOrigin:
    """A node whose mesh has several primitives: caustica makes one object of each (``name.k``), export
    writes them back as one node ``name`` while they stay together with one transform."""

    name: str


@dataclass
class GltfOrigin:
    """Records of the glTF parts of one scene, each keyed by id() of the caustica part it became."""

    extensions_required: list[str] = field(default_factory=list)
    materials: dict[int, tuple[object, MaterialOrigin]] = field(default_factory=dict)
    lights: dict[int, tuple[object, LightOrigin]] = field(default_factory=dict)
    cameras: dict[int, tuple[object, CameraOrigin]] = field(default_factory=dict)
    objects: dict[int, tuple[object, NodeOrigin]] = field(default_factory=dict)

    def add(self, table: str, part, record) -> None:
        """Remember ``record`` for ``part`` in ``table`` ('materials', 'lights', 'cameras' or 'objects')."""
        getattr(self, table)[id(part)] = (part, record)

    def of(self, table: str, part):
        """The record of ``part`` in ``table``, or None for a part that did not come from a glTF file."""
        kept = getattr(self, table).get(id(part))
        return kept[1] if kept is not None and kept[0] is part else None

    def camera(self, camera) -> CameraOrigin | None:
        """The record of ``camera``, or of the file's camera it was made from (the same eye, look_at and up,
        e.g. with another size): its names stay, and only what changed is written as caustica's."""
        record = self.of("cameras", camera)
        if record is not None:
            return record
        for kept, record in self.cameras.values():
            if all(np.array_equal(getattr(kept, key), getattr(camera, key)) for key in ("position", "look_at", "up")):
                return record
        return None

    def merged(self, other: "GltfOrigin") -> "GltfOrigin":
        """One record of two files' parts (a TOML scene with several gltf entries)."""
        required = self.extensions_required + [e for e in other.extensions_required
                                               if e not in self.extensions_required]
        return GltfOrigin(required, {**self.materials, **other.materials}, {**self.lights, **other.lights},
                          {**self.cameras, **other.cameras}, {**self.objects, **other.objects})


def origin_of(scene) -> GltfOrigin:
    """The scene's glTF record (an empty one for scenes that came from no glTF file)."""
    origin = getattr(scene, "gltf", None)
    return origin if isinstance(origin, GltfOrigin) else GltfOrigin()


def thin_walled_glass(scene) -> list[str]:
    """Names of the scene's glass objects whose glTF material has no KHR_materials_volume: thin-walled by
    the glTF spec, rendered solid by caustica (as Blender's Cycles does)."""
    origin = origin_of(scene)
    return [o.name for o in scene.objects if o.material.kind == "glass"
            and getattr(origin.of("materials", o.material), "thin_walled", False)]


def aspect_ratio(origin: CameraOrigin | None, size) -> float:
    """The aspectRatio to write: the file's own while the size is the one caustica made of it."""
    kept = origin.perspective.get("aspectRatio") if origin is not None and tuple(size) == tuple(origin.size) else None
    return float(kept) if kept is not None else size[0] / size[1]


def thin_walled_note(names: list[str], shown: int = 3) -> str:
    """One line on glass that glTF calls thin-walled and caustica renders solid."""
    more = f" and {len(names) - shown} more" if len(names) > shown else ""
    listed = ", ".join(repr(n) for n in names[:shown]) + more
    return (f"glass {listed}: its glTF material has no KHR_materials_volume, thin-walled by the glTF spec; "
            "rendered solid, as artists mean it and Cycles renders it (add KHR_materials_volume to say so)")


def camera_extras(origin: CameraOrigin | None, size, focus_distance: float) -> dict:
    """The ``extras.caustica`` of an exported camera: every key for a camera caustica made, else the keys
    the file had and those whose value the user changed since."""
    values = {"size": [int(v) for v in size], "focus_distance": float(focus_distance)}
    if origin is None:
        return values
    changed = {"size": tuple(size) != tuple(origin.size),
               "focus_distance": not np.isclose(focus_distance, origin.focus_distance, rtol=1e-9, atol=0.0)}
    return {key: value for key, value in values.items() if key in origin.extras_keys or changed[key]}
