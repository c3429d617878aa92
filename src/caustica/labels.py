"""Per-pixel label layers of a render: ``Renderer.render(scene, labels=[...])`` returns ``(image, layers)``.

The layers (docs/labels.md has units, channel names, costs): ``id`` (object index, -1 on the background),
``material`` (index into :func:`material_table`, -1), ``depth`` (view-space z: distance along the camera's
-Z axis; inf on the background), ``normal`` (world unit normal of the first surface, facing the eye; 0),
``glass`` (1 where the first surface is glass), ``flow`` (where the refracted path through a glass pixel
leaves the glass: ``flow`` its world direction, ``flow_object`` and ``flow_point`` the object and world
point it lands on, -1 and 0 where it escapes to the environment), ``caustic`` (intensity_scale times the
caustic irradiance on the diffuse surface seen first, 0 where no caustic technique ran) and ``alpha`` (the
fraction of a pixel's samples that an object covers).

Rasterized techniques take id, material, depth, normal, glass and caustic from one extra pass at pixel
centres (passes/post/labels.py), alpha from the supersampled frame; CPU techniques from Embree primary rays.
The flow is always the exact oracle's (raytrace/paths.py follow_refraction from each glass pixel's centre
ray, Embree), whatever technique drew the image. :func:`write_labels` and :func:`read_labels` keep them in
one multi-layer OpenEXR or one .npz.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .errors import OutputError, RenderOptionError, closest_name, short

LABELS = ("id", "material", "depth", "normal", "glass", "flow", "caustic", "alpha")
FLOW_LAYERS = ("flow", "flow_object", "flow_point")  # what the label "flow" returns
FORMATS = ("exr", "npz")
INTEGER_LAYERS = ("id", "material", "flow_object")  # int32; -1 where nothing
MASK_LAYERS = ("glass",)  # uint8 0/1
# EXR channel suffixes of each layer (a layer not listed: .V for one component, .R .G .B for three).
EXR_SUFFIXES = {"id": ("V",), "material": ("V",), "depth": ("Z",), "normal": ("X", "Y", "Z"), "glass": ("V",),
                "flow": ("X", "Y", "Z"), "flow_object": ("V",), "flow_point": ("X", "Y", "Z"),
                "caustic": ("R", "G", "B"), "alpha": ("A",)}


def check_labels(labels) -> tuple[str, ...]:
    """The label names asked for, in LABELS order without repeats; ``labels`` a list of names or one
    comma-separated string. RenderOptionError in one line on an unknown name (with the nearest and the list)."""
    names = labels.split(",") if isinstance(labels, str) else labels
    try:
        names = [str(name).strip() if isinstance(name, str) else name for name in names]
    except TypeError:
        raise RenderOptionError(f"labels {short(labels)} must be a list of label names; "
                                f"the labels are: {', '.join(LABELS)}") from None
    for name in names:
        if name not in LABELS:
            hint = closest_name(name, LABELS) if isinstance(name, str) else ""
            raise RenderOptionError(f"unknown label {short(name)}{hint}; the labels are: {', '.join(LABELS)}")
    return tuple(name for name in LABELS if name in names)


def check_technique_gives(technique, names) -> None:
    """RenderOptionError when ``technique`` (resolved) cannot give one of ``names``: the caustic layer of
    a CPU technique without a ``caustic_layer`` method (``mitsuba``: its caustics are not separable)."""
    if "caustic" in names and not technique.uses_gl and not hasattr(technique, "caustic_layer"):
        raise RenderOptionError(f"technique '{technique.name}' cannot give the caustic label (its caustics are "
                                "not a separate layer); use exact or a caustic technique such as "
                                "caustic-mapping, or drop 'caustic' from the labels")


def material_table(scene) -> list:
    """The scene's distinct materials (equal kind and fields), in the order objects first use them: the
    ``material`` label indexes this list."""
    first = {}
    for obj, index in zip(scene.objects, material_indices(scene)):
        first.setdefault(index, obj.material)
    return [first[index] for index in range(len(first))]


def material_indices(scene) -> list[int]:
    """Each object's index into :func:`material_table`."""
    keys, indices = [], []
    for obj in scene.objects:
        key = _material_key(obj.material)
        if key not in keys:
            keys.append(key)
        indices.append(keys.index(key))
    return indices


def _material_key(material) -> tuple:
    """A material's kind and field values: small arrays (colours) by content, large ones (textures) by
    identity, so that a frame never copies a texture to compare it."""
    fields = dataclasses.fields(material) if dataclasses.is_dataclass(material) else ()
    return (material.kind,) + tuple((f.name, _value_key(getattr(material, f.name))) for f in fields)


def _value_key(value):
    if not isinstance(value, np.ndarray):
        return value  # a number, None or a string
    return ("array", id(value)) if value.size > 16 else (value.dtype.str, value.shape, value.tobytes())


# Layers from the rasterized label pass ------------------------------------------------------------


def raster_layers(buffers: dict, names, scene, camera, supersampling: int) -> dict:
    """The layers ``names`` from passes/post/labels.py's buffers read back (read_label_buffers) at the output
    size of ``camera``; the flow traced from the glass mask."""
    from .gpu.readback import box_downsample

    surface, ids = buffers.get("label_surface"), buffers["label_ids"]  # the background cleared to 0
    covered = ids[..., 3] > 0.5
    layers = {}
    if "id" in names:
        layers["id"] = np.rint(ids[..., 0]).astype(np.int32) - 1
    if "material" in names:
        layers["material"] = np.rint(ids[..., 1]).astype(np.int32) - 1
    if "depth" in names:
        layers["depth"] = np.where(covered, surface[..., 3], np.float32(np.inf))
    if "normal" in names:
        layers["normal"] = np.ascontiguousarray(surface[..., :3])
    glass = ids[..., 2] > 0.5
    if "glass" in names:
        layers["glass"] = glass.astype(np.uint8)
    if "flow" in names:
        layers.update(flow_layers(scene, camera, glass))
    if "caustic" in names:
        caustic = buffers.get("label_caustic")
        layers["caustic"] = (np.zeros(covered.shape + (3,), np.float32) if caustic is None
                             else np.ascontiguousarray(caustic[..., :3]))
    if "alpha" in names:
        coverage = buffers.get("label_coverage")
        alpha = covered.astype(np.float32) if coverage is None else box_downsample(coverage, supersampling)[..., 0]
        layers["alpha"] = np.ascontiguousarray(alpha, dtype=np.float32)
    return layers


# Layers from Embree (CPU techniques) --------------------------------------------------------------


def traced_layers(scene, camera, spp: int, names, technique=None, params=None) -> dict:
    """The layers ``names`` from Embree primary rays through pixel centres (alpha: through ``spp``
    stratified samples, as exact renders them); the caustic layer from ``technique.caustic_layer(scene,
    camera, params, hits)`` (check_technique_gives refuses a technique without one)."""
    from .raytrace.embree_scene import ray_scene_for

    width, height = camera.size
    rays = ray_scene_for(scene)
    origins, dirs = (a.reshape(-1, 3) for a in camera.primary_rays(1))
    hits = rays.intersect(origins, dirs)
    index = hits.object_index
    layers = {}
    if "id" in names:
        layers["id"] = index.reshape(height, width).astype(np.int32)
    if "material" in names:
        table = np.array(material_indices(scene) + [-1], dtype=np.int32)  # index -1 reads the last entry
        layers["material"] = table[index].reshape(height, width)
    if "depth" in names:
        forward = -camera.view_from_world()[2, :3]
        depth = np.where(hits.hit, hits.t * (dirs @ forward), np.inf)
        layers["depth"] = depth.reshape(height, width).astype(np.float32)
    if "normal" in names:
        facing = np.where((np.einsum("ij,ij->i", hits.normal, dirs) > 0)[:, None], -hits.normal, hits.normal)
        layers["normal"] = facing.reshape(height, width, 3).astype(np.float32)
    kinds = np.array([obj.material.kind == "glass" for obj in scene.objects] + [False])
    glass = kinds[index].reshape(height, width)
    if "glass" in names:
        layers["glass"] = glass.astype(np.uint8)
    if "flow" in names:
        layers.update(flow_layers(scene, camera, glass))
    if "caustic" in names:
        layers["caustic"] = np.asarray(technique.caustic_layer(scene, camera, params, hits), dtype=np.float32)
    if "alpha" in names:
        if spp <= 1:
            alpha = hits.hit.reshape(height, width)
        else:
            sample_origins, sample_dirs = camera.primary_rays(spp)
            covered = rays.intersect(sample_origins.reshape(-1, 3), sample_dirs.reshape(-1, 3)).hit
            alpha = covered.reshape(height, width, -1).mean(axis=2)
        layers["alpha"] = np.asarray(alpha, dtype=np.float32)
    return layers


def flow_layers(scene, camera, glass: np.ndarray) -> dict:
    """Refractive flow of the ``glass`` (H, W) pixels, by the exact oracle: each centre ray's refracted
    branch followed through the glass (follow_refraction: TIR reflects inside) to what it lands on.

    ``flow``: the world direction it leaves the glass along, or, where it meets an object inside the glass
    (an open water surface over a floor), its direction inside (0 outside the mask and where the path is
    invalid: it leaks, exceeds 16 interfaces, or meets no glass, at a silhouette the rasterizer and Embree
    disagree on); ``flow_object``: the object it lands on (-1: the environment, or no flow);
    ``flow_point``: the world point there (0 where none)."""
    from .raytrace.embree_scene import ray_scene_for
    from .raytrace.paths import follow_refraction

    height, width = glass.shape
    direction = np.zeros((height * width, 3), np.float32)
    landed = np.full(height * width, -1, np.int32)
    point = np.zeros((height * width, 3), np.float32)
    pixels = np.flatnonzero(glass.ravel())
    if len(pixels):
        rows = pixels // width
        first, stop = int(rows.min()), int(rows.max()) + 1
        origins, dirs = camera.primary_rays(1, rows=(first, stop))
        inside = pixels - first * width
        rays = ray_scene_for(scene)
        paths = follow_refraction(rays, scene, origins.reshape(-1, 3)[inside], dirs.reshape(-1, 3)[inside])
        # Valid paths, and those that meet an object inside glass (the floor under water): they see it.
        ok = (paths.valid | (paths.landed_object >= 0)) & (paths.interfaces > 0)
        done = pixels[ok]
        direction[done] = paths.direction[ok]
        landed[done] = paths.landed_object[ok]
        point[done] = paths.landed_position[ok]
    return dict(zip(FLOW_LAYERS, (direction.reshape(height, width, 3), landed.reshape(height, width),
                                  point.reshape(height, width, 3))))


# Files ------------------------------------------------------------------------------------------


def labels_file(stem: str, format: str = "exr") -> str:
    """The name of the labels file of the image whose name, suffix dropped, is ``stem``:
    ``frame_000012`` -> ``frame_000012.labels.exr`` (batch frames and ``caustica render --labels``)."""
    return f"{stem}.labels.{format}"


def write_labels(path, layers: dict, format: str | None = None) -> Path:
    """Write ``layers`` ({name: (H, W) or (H, W, C) array}) to one file, atomically: ``format`` 'exr'
    (one multi-layer OpenEXR, channels ``name.suffix`` as EXR_SUFFIXES; integer layers as exact FLOAT
    values, the glass mask as UINT) or 'npz' (one compressed numpy archive); None: from the suffix."""
    from .atomic import write_atomic
    from .images import write_exr_channels

    path = Path(path)
    format = _format_of(path, format)
    arrays = _checked_layers(layers, path)
    if format == "npz":
        def save(tmp: str) -> None:
            with open(tmp, "wb") as out:
                np.savez_compressed(out, **arrays)

        return write_atomic(path, save)
    channels = {}
    for name, array in arrays.items():
        planes = array[..., None] if array.ndim == 2 else array
        suffixes = EXR_SUFFIXES.get(name) or (("V",) if planes.shape[2] == 1 else tuple("RGB"))
        if len(suffixes) != planes.shape[2]:
            raise OutputError(f"cannot write {path}: layer '{name}' has {planes.shape[2]} components, "
                              f"expected {len(suffixes)}")
        dtype = np.uint32 if name in MASK_LAYERS else np.float32
        for c, suffix in enumerate(suffixes):
            channels[f"{name}.{suffix}"] = np.ascontiguousarray(planes[..., c], dtype=dtype)
    return write_exr_channels(path, channels)


def read_labels(path) -> dict:
    """The layers of a file :func:`write_labels` wrote, with the dtypes the renderer returns (int32 ids,
    uint8 glass mask, float32 otherwise)."""
    from .images import read_exr_channels

    path = Path(path)
    format = _format_of(path, None)
    if not path.is_file():
        raise OutputError(f"label file not found: {path}; check the path")
    if format == "npz":
        try:
            with np.load(path, allow_pickle=False) as archive:
                return {name: _restored(name, archive[name]) for name in archive.files}
        except (OSError, ValueError) as exc:
            raise OutputError(f"cannot read labels {path}: {exc}; check that it is a .npz write_labels wrote") from None
    channels = read_exr_channels(path, OutputError)
    grouped: dict[str, dict[str, np.ndarray]] = {}
    for full, pixels in channels.items():
        name, _, suffix = full.rpartition(".")
        grouped.setdefault(name or full, {})[suffix] = pixels
    layers = {}
    for name, parts in grouped.items():
        order = EXR_SUFFIXES.get(name) or (("V",) if len(parts) == 1 else tuple("RGB"))
        if set(order) != set(parts):
            raise OutputError(f"cannot read labels {path}: layer '{name}' has channels {sorted(parts)}, "
                              f"expected {list(order)}")
        planes = [parts[s] for s in order]
        layers[name] = _restored(name, planes[0] if len(planes) == 1 else np.stack(planes, axis=-1))
    return layers


def _restored(name: str, array: np.ndarray) -> np.ndarray:
    if name in INTEGER_LAYERS:
        return np.asarray(array).astype(np.int32)
    if name in MASK_LAYERS:
        return np.asarray(array).astype(np.uint8)
    return np.asarray(array, dtype=np.float32)


def _format_of(path: Path, format: str | None) -> str:
    suffix = path.suffix.lower().lstrip(".")
    if format is None:
        if suffix not in FORMATS:
            raise OutputError(f"label file {path} must end in .exr or .npz (or give format='exr' or 'npz')")
        return suffix
    if format not in FORMATS:
        raise OutputError(f"unknown label format {short(format)}{closest_name(str(format), FORMATS)}; "
                          f"use one of {', '.join(FORMATS)}")
    return format


def _checked_layers(layers: dict, path: Path) -> dict:
    """``layers`` as arrays of one (H, W) size with plain names, or OutputError in one line."""
    if not isinstance(layers, dict) or not layers:
        raise OutputError(f"cannot write {path}: give the layers as a non-empty dict of arrays")
    arrays, size = {}, None
    for name, value in layers.items():
        array = np.asarray(value)
        if not isinstance(name, str) or not name.isidentifier():
            raise OutputError(f"cannot write {path}: layer name {short(name)} must be a plain name such as 'depth'")
        if array.ndim not in (2, 3) or array.size == 0 or (size is not None and array.shape[:2] != size):
            raise OutputError(f"cannot write {path}: layer '{name}' has shape {array.shape}; every layer must "
                              f"be (H, W) or (H, W, C) of one size{'' if size is None else f' {size}'}")
        size = array.shape[:2]
        arrays[name] = array
    return arrays
