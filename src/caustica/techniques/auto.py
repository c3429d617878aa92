"""``auto``: the technique that renders each scene with its plan (:mod:`caustica.planning.rules`).

``quality`` picks the plan's parameters; ``budget_ms`` instead takes the highest quality whose frame time, measured
on this device at this size and cached on disk (``$CAUSTICA_CACHE/costs``), fits the budget. Any other parameter goes
to the planned technique.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import TechniqueError
from ..lighting.bake import MAX_BAKE_SIZE
from ..lighting.environment import LOBES, MAX_LOBES
from ..planning.probes import occluded_ambient
from ..planning.rules import QUALITY, Plan, plan
from ..raytrace.environment_bake import BAKE_SIZE
from ..scene.scene import without_invisible_glass
from .base import Params, Technique, param
from .registry import get_technique


@dataclass
class AutoParams(Params):
    """Parameters of ``auto``."""

    quality: str = param("balanced", choices=tuple(QUALITY),
                         help="draft (fastest), balanced, or high (more internal bounces, larger maps); "
                              "any other parameter goes to the planned technique")
    budget_ms: float = param(0.0, range=(0.0, 1e6), special={0: "none: quality decides"}, unit="ms",
                             help="frame-time budget: the highest quality whose measured frame time fits")
    environment_lobes: int = param(LOBES, range=(0, MAX_LOBES), special={0: "none: unoccluded SH ambient"},
                                   help="the environment's strata of equal power whose light on diffuse surfaces is "
                                        "shadowed (one directional shadow map each; docs/environment-light.md), "
                                        "where the plan finds diffuse surfaces that other objects occlude")
    environment_bake: int = param(BAKE_SIZE, range=(0, MAX_BAKE_SIZE), special={0: "none"}, unit="texels",
                                  help="texels a side of the floor's light map of the environment's light (box "
                                       "faces get 16, planes up to this, curved receivers per vertex), baked once "
                                       "per scene state with exact's rays (occlusion, glass, the sky's caustic, one "
                                       "bounce; docs/environment-light.md), where objects occlude diffuse receivers")


class Auto(Technique):
    """``auto``: the plan's technique for each scene (:func:`plan`)."""

    name = "auto"
    summary = "The most accurate real-time combination for the scene: impostors, depth-search or per-vertex, with caustics"
    Params = AutoParams
    role = "planner"
    plan_used: Plan | None = None  # the plan of the last for_scene (the renderer keeps it as last_plan)

    def make_params(self, **values):
        """``quality``, ``budget_ms``, and any other parameter for the planned technique (checked once
        the plan is made)."""
        own = {name: values.pop(name) for name in ("quality", "budget_ms", "environment_lobes", "environment_bake")
               if name in values}
        params = super().make_params(**own)
        params.overrides = values  # not a field: what the plan's technique takes depends on the scene
        params.given = frozenset(own)  # auto's own parameters named by the caller: they win over the plan's rules
        return params

    def for_scene(self, scene, params, frame_ms=None, frame_size=None):
        """The planned technique and its parameters. With a budget, ``frame_ms(technique, params)``
        (the renderer's measured, cached frame time) picks the highest quality that fits;
        ``frame_size``: the supersampled pixels of the frame (the caustic map follows it)."""
        if not params.budget_ms:
            return self._planned(scene, params.quality, params, frame_size)
        if frame_ms is None:
            raise TechniqueError("auto's budget_ms needs frame times measured by a Renderer; render through one")
        costs = {}
        for quality in ("high", "balanced", "draft"):
            technique, values = self._planned(scene, quality, params, frame_size)
            costs[quality] = frame_ms(technique, values)
            if costs[quality] <= params.budget_ms:
                measured = ", ".join(f"{name} {ms:.1f} ms" for name, ms in costs.items())
                self.plan_used.notes.append(f"budget {params.budget_ms:g} ms: {quality}, the highest quality that "
                                            f"fits (measured here: {measured})")
                return technique, values
        # The cheapest as measured (a loaded moment may time draft above balanced): what the smallest budget is.
        cheapest = min(costs, key=costs.get)
        raise TechniqueError(f"budget {params.budget_ms:g} ms is below the cheapest plan's {costs[cheapest]:.1f} ms "
                             f"per frame here ({cheapest}); give a budget of {costs[cheapest] * 1.1:.0f} ms or more, "
                             "or a smaller size")

    def _planned(self, scene, quality: str, params, frame_size=None):
        chosen = self.plan_used = plan(scene, quality, frame_size)
        technique = get_technique(chosen.technique)
        overrides = getattr(params, "overrides", {})
        try:
            values = technique.make_params(**{**chosen.params, **overrides})
        except TechniqueError as exc:  # the list of parameters is the planned technique's: point to it
            reason = str(exc).split("; its parameters are:")[0]
            raise TechniqueError(f"auto planned '{chosen.technique}' for this scene: {reason}; "
                                 f"see 'caustica techniques {chosen.technique}'") from None
        # The environment's light (the light passes read the view's: bake_settings, lobe_settings).
        view_values = values[0] if isinstance(values, tuple) else values  # a composite's: (view, caustics)
        given = getattr(params, "given", ())
        # Lobes named without a light map: the lobes light the floor too (the rule set aside for both).
        bake = params.environment_bake if "environment_bake" in given or (
            "environment_lobes" not in given and "environment_bake" in chosen.params) else 0
        # The light maps replace the lobes (the lobes' change beside the floor's map did not pay: docs/auto.md); with
        # every receiver baked none is left to them.
        lobes = params.environment_lobes if "environment_lobes" in given or (
            not bake and occluded_ambient(without_invisible_glass(scene))) else 0
        for name, value in (("environment_bake", bake), ("environment_lobes", lobes)):
            for half in values if isinstance(values, tuple) else (values,):
                setattr(half, name, value if half is view_values else 0)
            # The plan's parameters are what renders: the planned technique named with them gives auto's image.
            chosen.params.pop(name, None)
            if value:
                chosen.params[name] = value
            if name in given:
                chosen.notes.append(f"{name}={getattr(params, name)} as given (the plan's rule set aside)")
        return technique, values
