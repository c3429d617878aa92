"""``per-object``: each glass object shown by its own view technique, in one image.

``techniques`` maps glass object names to view techniques (those that declare
a ``view_order``: ``env-map``, ``image-space``, ``depth-search``); every other
object (and every glass object not named) takes ``default``. The passes are the union of what the chosen techniques need
before shading (shadow maps, refractor front/back buffers, image-space's d_N
buffer), each channel made once, then one :class:`ShadeSurfaces` run per
technique: the first (the default technique, which also shades diffuse
receivers and mirrors) clears and draws the background, the others draw only
their objects over it, depth tested against the same depth buffer. A glass
object's pixels are therefore exactly those of a full render with its
technique, which reads the same buffers of all refractors.

Each chosen technique runs with its own parameters, given qualified by its
name (``-p depth-search.iterations=3``, ``image-space.tir_mode=reflect``; kept
in ``technique_params``), and its defaults otherwise; ``shadow_map_size`` is
shared by all (and with a caustic technique in ``per-object+caustic-mapping``).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import TechniqueError, closest_name
from ..passes.shading.surfaces import RefractorSurfaces, ShadeBackground, ShadeSurfaces
from ..render.frame import Pass
from .base import param
from .env_map import ShadowedParams
from .raster import RasterTechnique
from .registry import get_technique, view_technique_names

VIEW_TECHNIQUES = view_technique_names()  # those that declare a view_order (base.Technique)


def _check_view_technique(technique, subject: str) -> None:
    """ValueError, ``<subject> must be one of <the view techniques>`` with a hint, unless ``technique`` is one."""
    if technique not in VIEW_TECHNIQUES:
        raise ValueError(f"{subject} must be one of {', '.join(VIEW_TECHNIQUES)}"
                         f"{closest_name(str(technique), VIEW_TECHNIQUES)}")


@dataclass
class PerObjectParams(ShadowedParams):
    """Parameters of ``per-object``: ``techniques`` maps glass object names to view techniques.

    ``techniques`` may also be written ``"name=technique,name=technique"`` (the command line's ``-p``).
    """

    techniques: dict[str, str] = param({}, kind="mapping", choices=VIEW_TECHNIQUES,
                                       help="glass object name -> its view technique ('name=technique,...' on -p)")
    default: str = param("depth-search", choices=VIEW_TECHNIQUES, help="view technique of the objects not named")
    technique_params: dict[str, dict] = param({}, kind="mapping", choices=VIEW_TECHNIQUES,
                                              help="view technique -> its parameters (-p technique.name=value)")

    def __post_init__(self):
        super().__post_init__()
        if isinstance(self.techniques, str):
            self.techniques = _parse_mapping(self.techniques)
        if not isinstance(self.techniques, dict):
            raise ValueError(f"techniques {self.techniques!r} must map object names to view techniques")
        for name, technique in self.techniques.items():
            _check_view_technique(technique, f"technique {technique!r} of object '{name}'")
        self.techniques = {str(k): str(v) for k, v in self.techniques.items()}
        if not isinstance(self.technique_params, dict):
            raise ValueError(f"technique_params {self.technique_params!r} must map view techniques to parameters")
        for technique, values in self.technique_params.items():
            _check_view_technique(technique, f"parameters for {technique!r}: it")
            if "shadow_map_size" in values:
                raise ValueError("shadow_map_size is shared by every technique of per-object; set it unqualified")
            self.params_for(technique)  # rejects unknown names and bad values now, with the technique's message

    def params_for(self, technique: str):
        """The parameters ``technique`` runs with here: its own settings and the shared shadow map size."""
        values = {**self.technique_params.get(technique, {}), "shadow_map_size": self.shadow_map_size}
        try:
            return get_technique(technique).make_params(**values)
        except TechniqueError as exc:
            message = str(exc).removeprefix(f"technique '{technique}': ")
            raise ValueError(message if message.startswith("technique '") else f"{technique} {message}") from None

    def technique_of(self, obj) -> str:
        """The view technique that shades ``obj`` (non-glass objects: the default)."""
        return self.techniques.get(obj.name, self.default) if obj.material.kind == "glass" else self.default


def _parse_mapping(text: str) -> dict[str, str]:
    mapping = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, sep, technique = item.partition("=")
        if not sep or not name.strip() or not technique.strip():
            raise ValueError(f"techniques item '{item}' must read object=technique, e.g. ball=env-map")
        mapping[name.strip()] = technique.strip()
    return mapping


class CheckObjectNames(Pass):
    """Checks that every object named in ``techniques`` is a glass object of the scene (before any GPU work)."""

    reads = ()
    writes = ()

    def __init__(self, names):
        self.names = tuple(names)

    def run(self, frame) -> None:
        glass = [o.name for o in frame.scene.objects_of("glass")]
        for name in self.names:
            if name not in glass:
                raise TechniqueError(
                    f"technique 'per-object': '{name}' is not a glass object of scene '{frame.scene.name}'"
                    f"{closest_name(name, glass)}; glass objects: {', '.join(glass) or 'none'}")


class PerObject(RasterTechnique):
    name = "per-object"
    summary = f"A view technique per glass object ({', '.join(VIEW_TECHNIQUES)}) in one image"
    Params = PerObjectParams
    qualified_prefixes = VIEW_TECHNIQUES

    def make_params(self, **values):
        """``technique.name`` values (``depth-search.iterations``) go to that technique's parameters."""
        own, qualified = {}, {}
        names = {t.replace("-", "_"): t for t in VIEW_TECHNIQUES}
        for key, value in values.items():
            prefix, _, name = key.rpartition(".")
            if not prefix:
                own[key] = value
            elif prefix.replace("-", "_") in names:
                qualified.setdefault(names[prefix.replace("-", "_")], {})[name] = value
            else:
                raise TechniqueError(f"'{prefix}' in parameter '{key}' is not a technique of per-object; "
                                     f"use one of {', '.join(VIEW_TECHNIQUES)}")
        if qualified:
            merged = {t: dict(v) for t, v in own.get("technique_params", {}).items()}
            for technique, settings in qualified.items():
                merged.setdefault(technique, {}).update(settings)
            own["technique_params"] = merged
        return super().make_params(**own)

    def build_passes(self, params):
        order = [params.default] + [t for t in dict.fromkeys(params.techniques.values()) if t != params.default]
        before, shades, made = [CheckObjectNames(params.techniques)], [], set()
        for technique in order:
            passes = get_technique(technique).build_passes(params.params_for(technique))
            at = next(i for i, p in enumerate(passes) if isinstance(p, ShadeSurfaces))
            if passes[at].captures_front_surface:  # restricted runs cannot: the buffer is drawn beforehand
                passes.insert(at, RefractorSurfaces("front", "nearest"))
                at += 1
            for stage in passes[:at]:  # each channel made once: the techniques' buffers are alike
                key = tuple(c.name for c in stage.writes)
                if isinstance(stage, RefractorSurfaces) and stage.absorbing_only:
                    stage = RefractorSurfaces(stage.face, stage.order)  # another technique may read every face
                if key not in made:
                    made.add(key)
                    before.append(stage)
            shades.append(_restricted(passes[at], technique, params, first=not shades))
        return before + shades + [ShadeBackground()]


def _restricted(shade: ShadeSurfaces, technique: str, params: PerObjectParams, first: bool) -> ShadeSurfaces:
    """``shade`` limited to the objects ``technique`` shades; only the first run clears the targets."""
    return ShadeSurfaces(shade.fragment, shade.defines, shade.material_override, shade.inputs, shade.set_uniforms,
                         objects=lambda obj: params.technique_of(obj) == technique, background=first, tag=technique,
                         vertex=shade.vertex, frame_defines=shade.frame_defines, deferred=shade.deferred,
                         staged=shade.staged)
