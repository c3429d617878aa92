"""glTF 2.0's metallic-roughness BRDF at ray hits for the ``exact`` oracle: the surface read from the
material's factors and textures, evaluated and importance-sampled (docs/materials.md).

The BRDF is the specification's Appendix B with KHR_materials_specular's dielectric reflectance, its two
lobes weighted to conserve energy (microfacet.layer_weights): f = s(v) (1 - metallic) base / pi +
c(v) F(v.h) D G2 / (4 cos_l cos_v), with F Schlick's Fresnel of f0 = (1 - metallic) f0_d + metallic base
(Schlick is affine in f0, so this is the spec's mix of the dielectric and the metal), f0_d =
min(0.04 specular_color, 1) specular, c the multiple-scattering compensation and s what the dielectric's
lobe leaves to the base. The GGX terms are :mod:`caustica.scene.microfacet`'s; the real-time shaders use the
same weights. Sampling picks the specular lobe with a probability from
Fresnel at the view (its reflectance against the diffuse part's), draws it by Heitz's visible normals and
the diffuse one by cosine, and weighs the direction by the mixture's density (one-sample MIS over the two
lobes). Textures: base colour, metallic-roughness (G roughness, B metallic), tangent-space normal maps
(tangent frames of :func:`caustica.scene.tangents.mesh_tangents`, interpolated with the hit's
barycentrics like the normals) and emission; occlusion is not read (a path tracer traces what it
approximates).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import microfacet
from ..scene.tangents import mesh_tangents
from ..scene.textures import sample_texture
from .environment_light import tangent_frame
from .optics import dot, normalize

MIN_SPECULAR_CHOICE = 0.1  # the least probability of either lobe where both reflect (keeps both sampled)


@dataclass
class SurfaceTable:
    """One Principled object as hits read it: the material and its world mesh's per-corner uvs and tangent
    frames (None without uvs: its textures are not read)."""

    material: object
    corner_uvs: np.ndarray | None  # (M, 3, 2)
    corner_tangents: np.ndarray | None  # (M, 3, 4) world-space xyz and handedness w

    @classmethod
    def of(cls, obj) -> "SurfaceTable":
        material, mesh = obj.material, obj.mesh
        if mesh.uvs is None:
            return cls(material, None, None)
        world = obj.world_mesh()  # its faces are the ones hit (reversed under a mirroring transform)
        tangents = None
        if material.normal_texture is not None:
            local = np.asarray(mesh_tangents(mesh), np.float64)
            m = obj.world_from_object()[:3, :3]
            xyz = local[:, :3] @ m.T  # tangents are directions in the surface: they map by the matrix itself
            tangents = np.c_[xyz, local[:, 3] * np.sign(np.linalg.det(m))][world.faces]
        return cls(material, world.uvs[world.faces], tangents)


@dataclass
class Surface:
    """The BRDF's inputs at n hits: shading normal (unflipped, the mesh's side), and per hit the colours
    and lobes."""

    normal: np.ndarray  # (n, 3)
    diffuse_color: np.ndarray  # (n, 3) (1 - metallic) base colour
    f0: np.ndarray  # (n, 3) specular reflectance at normal incidence
    f0_dielectric: np.ndarray  # (n, 3) the dielectric's share's, which the diffuse part is less of
    alpha: np.ndarray  # (n,) GGX alpha
    emission: np.ndarray  # (n, 3) emitted radiance, before intensity_scale

    def rows(self, which) -> "Surface":
        """The surface at a subset of its hits (a mask or indices)."""
        return Surface(self.normal[which], self.diffuse_color[which], self.f0[which], self.f0_dielectric[which],
                       self.alpha[which], self.emission[which])


def read_surface(tables: dict, hits, where: np.ndarray, normal: np.ndarray) -> Surface:
    """The :class:`Surface` at the ``where`` hits (their objects all in ``tables``, object index ->
    :class:`SurfaceTable`), whose interpolated normals are ``normal`` (n, 3)."""
    rows = np.flatnonzero(where)
    index = hits.object_index[rows]
    n = len(rows)
    base, metallic, roughness = np.zeros((n, 3)), np.zeros(n), np.zeros(n)
    f0_d, emission, out_normal = np.zeros((n, 3)), np.zeros((n, 3)), np.array(normal, np.float64, copy=True)
    for k in np.unique(index):
        table, on = tables[int(k)], index == k
        m = table.material
        base[on], metallic[on], roughness[on] = m.base_color, m.metallic, m.roughness
        f0_d[on] = m.dielectric_f0
        emission[on] = m.emission
        if table.corner_uvs is None:
            continue
        faces, bary = hits.face[rows[on]], hits.barycentric[rows[on]]
        uv = np.einsum("ik,ikj->ij", bary, table.corner_uvs[faces])
        if m.base_color_texture is not None:
            base[on] *= sample_texture(m.base_color_texture, uv)
        if m.metallic_roughness_texture is not None:
            texel = sample_texture(m.metallic_roughness_texture, uv)
            roughness[on] *= texel[:, 1]
            metallic[on] *= texel[:, 2]
        if m.emission_texture is not None:
            emission[on] *= sample_texture(m.emission_texture, uv)
        if table.corner_tangents is not None:
            frame = np.einsum("ik,ikj->ij", bary, table.corner_tangents[faces])
            texel = sample_texture(m.normal_texture, uv) * 2.0 - 1.0
            out_normal[on] = mapped_normal(out_normal[on], frame, texel, m.normal_scale)
    diffuse_color = (1.0 - metallic)[:, None] * base
    f0 = (1.0 - metallic)[:, None] * f0_d + metallic[:, None] * base
    return Surface(out_normal, diffuse_color, f0, f0_d, microfacet.alpha_of(roughness), emission)


def mapped_normal(normal: np.ndarray, tangent: np.ndarray, texel: np.ndarray, scale: float) -> np.ndarray:
    """glTF's tangent-space normal mapping: ``texel`` (n, 3) in [-1, 1], x and y scaled by ``scale``, in the
    frame of the unit ``normal`` (n, 3), the interpolated ``tangent`` (n, 4) made orthogonal to it, and the
    bitangent w cross(normal, tangent) (up the image)."""
    t = tangent[:, :3] - normal * dot(normal, tangent[:, :3])[:, None]
    t = normalize(t)
    b = np.where(tangent[:, 3:4] < 0, -1.0, 1.0) * np.cross(normal, t)
    mapped = scale * texel[:, :1] * t + scale * texel[:, 1:2] * b + texel[:, 2:3] * normal
    return normalize(mapped)


def evaluate(surface: Surface, normal: np.ndarray, view: np.ndarray, light: np.ndarray) -> np.ndarray:
    """The BRDF (n, 3) for unit ``view`` and ``light`` directions (n, 3, pointing away from the surface)
    about the shading ``normal`` (n, 3) facing the viewer; 0 where either lies below it."""
    n_dot_l, n_dot_v = dot(normal, light), dot(normal, view)
    half = normalize(view + light)
    v_dot_h, n_dot_h = dot(view, half), dot(normal, half)
    specular = microfacet.specular_brdf(n_dot_l, n_dot_v, n_dot_h, v_dot_h, surface.alpha, surface.f0)
    compensation, diffuse_share = microfacet.layer_weights(surface.f0, surface.f0_dielectric, n_dot_v,
                                                           np.sqrt(surface.alpha))
    specular = specular * compensation
    diffuse = surface.diffuse_color / np.pi * diffuse_share
    above = (n_dot_l > 0) & (n_dot_v > 0)
    return np.where(above[:, None], specular + diffuse, 0.0)


def specular_choice(surface: Surface, n_dot_v: np.ndarray) -> np.ndarray:
    """(n,) the probability of sampling the specular lobe: its Fresnel reflectance at the view against the
    diffuse part's albedo (means over the channels), kept in [MIN_SPECULAR_CHOICE, 1 - it] where both
    reflect."""
    cos = n_dot_v[:, None]
    specular = microfacet.schlick(surface.f0, cos).mean(axis=1)
    diffuse = (surface.diffuse_color * (1.0 - microfacet.schlick(surface.f0_dielectric, cos))).mean(axis=1)
    total = specular + diffuse
    p = np.where(total > 0, specular / np.maximum(total, 1e-300), 0.5)
    both = (specular > 0) & (diffuse > 0)
    return np.where(both, np.clip(p, MIN_SPECULAR_CHOICE, 1.0 - MIN_SPECULAR_CHOICE), np.where(diffuse > 0, 0.0, 1.0))


def density(surface: Surface, normal, view, light, p_specular) -> np.ndarray:
    """(n,) the solid-angle density of :func:`sample` choosing ``light``: p_s G1(v) D(h) / (4 cos_v) +
    (1 - p_s) cos_l / pi."""
    n_dot_l, n_dot_v = np.clip(dot(normal, light), 0.0, 1.0), np.clip(dot(normal, view), 1e-12, 1.0)
    n_dot_h = dot(normal, normalize(view + light))
    specular = (microfacet.masking(n_dot_v, surface.alpha) * microfacet.distribution(n_dot_h, surface.alpha)
                / (4.0 * n_dot_v))
    return p_specular * specular + (1.0 - p_specular) * n_dot_l / np.pi


def sample(surface: Surface, normal: np.ndarray, view: np.ndarray, u: np.ndarray):
    """Directions (n, 3) drawn from the BRDF for numbers ``u`` (n, 3) in [0, 1) (the lobe, then two for the
    direction) and their weights f cos_l / density (n, 3); 0 where the direction falls below ``normal``."""
    t, s = tangent_frame(normal)
    local_view = np.stack([dot(view, t), dot(view, s), dot(view, normal)], axis=1)
    local_view[:, 2] = np.maximum(local_view[:, 2], 1e-9)
    p_specular = specular_choice(surface, local_view[:, 2])
    h = microfacet.sample_visible_normal(local_view, surface.alpha, u[:, 1], u[:, 2])
    specular = microfacet.reflect(local_view, h)
    r, phi = np.sqrt(u[:, 1]), 2.0 * np.pi * u[:, 2]
    cosine = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0.0, 1.0 - u[:, 1]))], axis=1)
    local = np.where((u[:, 0] < p_specular)[:, None], specular, cosine)
    light = local[:, :1] * t + local[:, 1:2] * s + local[:, 2:3] * normal
    pdf = density(surface, normal, view, light, p_specular)
    f = evaluate(surface, normal, view, light)
    cos = np.clip(dot(normal, light), 0.0, 1.0)
    weight = np.where((pdf > 0)[:, None], f * (cos / np.maximum(pdf, 1e-300))[:, None], 0.0)
    return light, weight
