"""Built-in scenes, loadable by name wherever a scene file is accepted."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .camera import Camera
from .environment import procedural_environment
from .lights import DirectionalLight, PointLight, SpotLight
from .materials import Diffuse, Glass, Mirror, water
from .mesh import Mesh
from .preset_parts import caustic_scene, floor_object, glass_model
from .presets_impostors import IMPOSTOR_PRESETS
from .presets_per_vertex import PER_VERTEX_PRESETS
from .presets_transport import TRANSPORT_PRESETS
from .scene import Scene, SceneObject
from .shapes import box, heightfield, plane, ring, sphere, water_heightfield
from .transform import Transform


def glass_sphere() -> Scene:
    """A unit glass sphere (IOR 1.5) in front of the sky-checker environment; no lights."""
    return Scene(
        camera=Camera(position=[0.0, 0.0, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=(512, 512)),
        objects=[SceneObject("sphere", sphere(1.0, subdivisions=5), Glass(ior=1.5))],
        environment=procedural_environment("sky-checker"),
        name="glass-sphere",
    )


def caustic_sphere() -> Scene:
    """A glass ball lens focusing a point light into a bright spot on a diffuse floor.

    The ball (radius 0.6, IOR 1.5) has focal length f = n R / (2 (n - 1)) = 0.9
    from its centre. With the light 2.8 above the centre, paraxial rays would
    focus f d / (d - f) = 1.33 below it; the ball's strong spherical aberration pulls the
    narrowest part of the focused beam closer, so the floor 1.2 below the
    centre catches the tightest spot (traced: half the flux within 0.01).
    """
    ball = SceneObject("ball", sphere(0.6, subdivisions=5), Glass(ior=1.5), Transform(position=[0.0, 1.2, 0.0]))
    floor = SceneObject("floor", plane((12.0, 12.0)), Diffuse(color=[0.5, 0.5, 0.5]))
    return Scene(
        camera=Camera(position=[0.0, 2.2, 4.2], look_at=[0.0, 0.5, 0.0], fov_y=40.0, size=(512, 512)),
        objects=[ball, floor],
        lights=[PointLight(position=[0.0, 4.0, 0.0], intensity=[20.0, 20.0, 20.0])],
        environment=procedural_environment("sky-checker"),
        name="caustic-sphere",
    )


def _sky_checker_scene(name: str, position, look_at, fov_y: float, objects, lights=()) -> Scene:
    """A 512x512 scene in the sky-checker environment (the TVCG presets and the glass models)."""
    return Scene(
        camera=Camera(position=position, look_at=look_at, fov_y=fov_y, size=(512, 512)),
        objects=list(objects), lights=list(lights), environment=procedural_environment("sky-checker"), name=name,
    )


def tvcg_fig10() -> Scene:
    """Hu and Qin's fig. 10: a unit sphere of IOR 0.8 (an air bubble in a denser medium).

    With n_t < n_i the view ray bends away from the normal, so many rays leave
    through a front-facing surface, and grazing rays are totally reflected at
    the entry. The sphere fills most of the frame, as in the paper's figure.
    """
    bubble = SceneObject("bubble", sphere(1.0, subdivisions=5), Glass(ior=0.8))
    return _sky_checker_scene("tvcg-fig10", [0.0, 0.0, 3.2], [0.0, 0.0, 0.0], 45.0, [bubble])


def tvcg_fig11() -> Scene:
    """Hu and Qin's fig. 11: refractive spheres of IOR 1.75 above a nearby diffuse plane.

    Three spheres (radius 0.5) stand in a row above a lit floor, as in the
    figure that compares Wyman's method, depth search and ray tracing; the
    spheres' edges show where the methods differ. Techniques that refract only
    the environment (env-map, image-space, depth-search) see the sky through
    the spheres where a ray tracer also sees the floor.
    """
    spheres = [SceneObject(f"sphere-{i}", sphere(0.5, subdivisions=5), Glass(ior=1.75),
                           Transform(position=[x, 0.5, 0.0])) for i, x in enumerate((-1.2, 0.0, 1.2))]
    floor = SceneObject("floor", plane((8.0, 8.0)), Diffuse(color=[0.6, 0.6, 0.6]))
    light = PointLight(position=[1.0, 4.0, 2.0], intensity=[15.0, 15.0, 15.0])
    return _sky_checker_scene("tvcg-fig11", [0.0, 1.8, 4.8], [0.0, 0.4, 0.0], 40.0, spheres + [floor], [light])


def glass_teapot() -> Scene:
    """A glass teapot (IOR 1.5), centred, about 2 units wide, in the sky-checker environment.

    Needs the shared data: ``models/teapot.obj`` under $CAUSTICA_DATA or ``../shared/data``.
    """
    teapot = glass_model("teapot.obj", "glass-teapot", 2.2, 1.5)
    return _sky_checker_scene("glass-teapot", [0.0, 1.2, 4.0], [0.0, 0.0, 0.0], 40.0, [teapot])


def glass_bunny() -> Scene:
    """The Stanford bunny in glass (IOR 1.5), scaled to about unit size and centred.

    Needs the shared data: ``models/stanford-bunny.obj`` under $CAUSTICA_DATA or ``../shared/data``.
    """
    bunny = glass_model("stanford-bunny.obj", "glass-bunny", 1.0, 1.5)
    return _sky_checker_scene("glass-bunny", [0.0, 0.4, 2.2], [0.0, 0.0, 0.0], 40.0, [bunny])


# Caustics ---------------------------------------------------------------------------------------
# Scenes made to show caustics on diffuse receivers: a dim sky (so the caustic dominates), a floor of
# albedo 0.7, the light aimed so that the caustic lies in view. `caustica.raytrace.photons` is their oracle.


def _ball(height: float = 0.95, radius: float = 0.5) -> SceneObject:
    """A glass ball lens (IOR 1.5, focal length 1.5 R from its centre) at x = z = 0."""
    return SceneObject("ball", sphere(radius, subdivisions=5), Glass(ior=1.5), Transform(position=[0.0, height, 0.0]))


_BALL_CAMERA = {"position": [0.0, 2.6, 3.4], "look_at": [0.0, 0.35, 0.25], "fov_y": 38.0}
_BALL_LIGHT = [0.0, 3.9, -1.0]  # behind the ball: the focused spot falls in front of its foot, towards the camera


def caustics_point() -> Scene:
    """A glass ball (R 0.5, IOR 1.5) over a floor under a point light behind and above it.

    The light 3.1 from the centre focuses (paraxial f = 0.75, spherical aberration pulls the tightest
    spot nearer) just above the floor, about 0.25 in front of the ball's foot, where the camera sees it.
    """
    light = PointLight(position=_BALL_LIGHT, intensity=[20.0, 20.0, 20.0])
    return caustic_scene("caustics-point", objects=[_ball(), floor_object()], lights=[light], **_BALL_CAMERA)


def caustics_spot() -> Scene:
    """``caustics-point`` under a spot light aimed at the ball (inner 12, outer 18 degrees).

    The ball subtends 9.3 degrees from the light, so the whole ball is lit at full intensity; the
    floor outside the cone is dark, which frames the caustic in a lit disc.
    """
    direction = -np.asarray(_BALL_LIGHT) + [0.0, 0.95, 0.0]
    light = SpotLight(position=_BALL_LIGHT, direction=direction, intensity=[20.0, 20.0, 20.0],
                      inner_angle=12.0, outer_angle=18.0)
    return caustic_scene("caustics-spot", objects=[_ball(), floor_object()], lights=[light], **_BALL_CAMERA)


def caustics_directional() -> Scene:
    """``caustics-point`` under a directional light (irradiance 2 W/m^2) slanting towards the camera.

    Parallel light focuses 0.75 from the centre (paraxial) and nearer at the rim; the ball stands
    0.85 above the floor so that the floor cuts the beam near its narrowest.
    """
    light = DirectionalLight(direction=[0.0, -1.0, 0.3], intensity=[2.0, 2.0, 2.0])
    return caustic_scene("caustics-directional", objects=[_ball(height=0.85), floor_object()], lights=[light],
                          **_BALL_CAMERA)


def caustics_bunny() -> Scene:
    """The Stanford bunny in amber glass (IOR 1.5, Beer-Lambert absorption) on a floor under a point light.

    The absorption colour [0.95, 0.6, 0.3] after 0.3 units tints the caustic by the path length through
    the body. Needs the shared data: ``models/stanford-bunny.obj`` under $CAUSTICA_DATA or ``../shared/data``.
    """
    bunny = glass_model("stanford-bunny.obj", "caustics-bunny", 1.2, 1.5)
    bunny.material = Glass(ior=1.5, absorption_color=[0.95, 0.6, 0.3], absorption_distance=0.3)
    low = bunny.world_mesh().bounds[0]
    floor = floor_object(height=float(low[1]) - 1e-3)
    light = PointLight(position=[0.5, 3.0, -1.5], intensity=[30.0, 30.0, 30.0])
    return caustic_scene("caustics-bunny", [0.0, 1.6, 3.2], [0.0, -0.2, 0.3], 40.0, [bunny, floor], [light])


def caustics_ring() -> Scene:
    """A metal ring (a mirror wall, inner radius 1, height 0.7) on a floor: the coffee-cup caustic.

    Light at 22 degrees elevation clears the near wall and hits the inner face of the far wall, which
    reflects it back as a cardioid-like (nephroid) caustic with its cusp about R / 2 from that wall on
    the floor inside the ring; the camera looks into the ring from the light's side.
    """
    elevation = np.radians(22.0)
    ring_object = SceneObject("ring", ring(1.0, 1.05, 0.7, segments=256), Mirror(color=[0.95, 0.9, 0.8]),
                              Transform(position=[0.0, 0.35, 0.0]))
    light = DirectionalLight(direction=[0.0, -np.sin(elevation), -np.cos(elevation)], intensity=[3.0, 3.0, 3.0])
    return caustic_scene("caustics-ring", [0.0, 3.4, 2.4], [0.0, 0.0, -0.2], 40.0, [ring_object, floor_object()], [light])


POOL_SIZE = 3.0  # side of the square pool
POOL_SHALLOW, POOL_DEEP = 0.5, 1.1  # floor depth below the water at the -X and +X ends


def _pool_floor_height(x, z):
    """Pool floor (y, dy/dx, dy/dz): shallow at -X, a smooth ramp (smoothstep) down to the deep end at +X."""
    t = np.clip(x / POOL_SIZE + 0.5, 0.0, 1.0)
    ramp = t * t * (3.0 - 2.0 * t)
    slope = np.where((t > 0) & (t < 1), 6.0 * t * (1.0 - t) / POOL_SIZE, 0.0)
    depth = POOL_DEEP - POOL_SHALLOW
    return -POOL_SHALLOW - depth * ramp, -depth * slope, np.zeros_like(z)


def pool_scene(time: float = 0.0) -> Scene:
    """A swimming pool: a water surface (IOR 1.33, slightly blue-green) over a sloping floor, four walls, sun.

    The water is ``shapes.water_heightfield`` at ``time`` (six travelling waves, amplitude 0.03), so
    animating ``time`` moves the caustic network on the floor; the floor ramps smoothly from 0.5 to
    1.1 below the surface, so the network focuses differently along the pool.
    """
    half = POOL_SIZE / 2.0
    surface = SceneObject("water", water_heightfield((POOL_SIZE, POOL_SIZE), resolution=160, amplitude=0.08,
                                                     waves=6, seed=3, time=float(time)),
                          water(absorption_color=[0.85, 0.95, 0.97], absorption_distance=1.0))
    bottom = SceneObject("pool-floor", heightfield((POOL_SIZE, POOL_SIZE), 96, _pool_floor_height, "pool-floor"),
                         Diffuse(color=[0.6, 0.75, 0.8]))
    wall_height, thickness = POOL_DEEP + 0.2, 0.1
    walls = []
    for i, (x, z, sx, sz) in enumerate([(half + thickness / 2, 0.0, thickness, POOL_SIZE + 2 * thickness),
                                        (-half - thickness / 2, 0.0, thickness, POOL_SIZE + 2 * thickness),
                                        (0.0, half + thickness / 2, POOL_SIZE, thickness),
                                        (0.0, -half - thickness / 2, POOL_SIZE, thickness)]):
        walls.append(SceneObject(f"wall-{i}", box((sx, wall_height, sz)), Diffuse(color=[0.75, 0.75, 0.7]),
                                 Transform(position=[x, 0.1 - wall_height / 2, z])))
    sun = DirectionalLight(direction=[0.25, -1.0, 0.15], intensity=[3.0, 3.0, 3.0])
    return caustic_scene("caustics-pool", [0.0, 3.6, 3.6], [0.0, -0.8, 0.0], 42.0, [surface, bottom] + walls, [sun])


def caustics_pool() -> Scene:
    """A swimming pool at time 0: water (IOR 1.33) over a sloping floor under the sun, its caustic network."""
    return pool_scene(0.0)


def _triangular_prism(side: float, length: float) -> Mesh:
    """A prism along Z whose cross-section is an equilateral triangle (apex up, centroid at the origin).

    Flat faces: every face has its own vertices and normal.
    """
    angles = np.radians([90.0, 210.0, 330.0])
    corners = side / np.sqrt(3.0) * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    front = [np.array([x, y, length / 2]) for x, y in corners]
    back = [np.array([x, y, -length / 2]) for x, y in corners]
    quads = [[front[i], front[(i + 1) % 3], back[(i + 1) % 3], back[i]] for i in range(3)]
    polygons = [front, back[::-1]] + quads
    vertices, normals, faces = [], [], []
    for poly in polygons:
        normal = np.cross(poly[1] - poly[0], poly[2] - poly[0])
        normal /= np.linalg.norm(normal)
        if np.dot(normal, np.mean(poly, axis=0)) < 0:  # wind counter-clockwise seen from outside
            poly, normal = poly[::-1], -normal
        base = len(vertices)
        vertices += poly
        normals += [normal] * len(poly)
        faces += [[base, base + k, base + k + 1] for k in range(1, len(poly) - 1)]
    return Mesh(np.array(vertices), np.array(normals), np.array(faces), name="prism")


def caustics_prism() -> Scene:
    """A dispersive glass prism (IOR 1.6, Abbe number 20) splitting a narrow spot light into colours on the floor.

    The 60-degree prism lies along Z, 1.3 above the floor, turned 37 degrees so that the spot, coming
    from the left 14 degrees downwards, meets it at minimum deviation (46 degrees for n = 1.6): the
    beam leaves 60 degrees downwards onto the floor to the right. Red (n = 1.597) is deviated least
    and blue (n = 1.627) most, about 0.05 rad apart, so the two ends of the spot are fringed red and blue.
    """
    center = np.array([0.0, 1.3, 0.0])
    prism = SceneObject("prism", _triangular_prism(0.6, 1.2), Glass(ior=1.6, abbe=20.0),
                        Transform(position=center, rotation=[0.0, 0.0, -37.0]))
    incoming = np.array([np.cos(np.radians(14.0)), -np.sin(np.radians(14.0)), 0.0])
    light = SpotLight(position=center - 3.0 * incoming, direction=incoming, intensity=[150.0, 150.0, 150.0],
                      inner_angle=1.0, outer_angle=1.5)
    return caustic_scene("caustics-prism", [1.4, 1.9, 3.0], [0.35, 0.62, 0.0], 40.0, [prism, floor_object()], [light])


def caustics_two_lights() -> Scene:
    """``caustics-point`` lit by two point lights, a warm and a cool one: two caustics side by side."""
    lights = [PointLight(position=[-1.2, 3.7, -1.0], intensity=[22.0, 16.0, 10.0]),
              PointLight(position=[1.2, 3.7, -1.0], intensity=[10.0, 16.0, 22.0])]
    return caustic_scene("caustics-two-lights", objects=[_ball(), floor_object()], lights=lights, **_BALL_CAMERA)


PRESETS: dict[str, Callable[[], Scene]] = {
    "glass-sphere": glass_sphere,
    "caustic-sphere": caustic_sphere,
    "tvcg-fig10": tvcg_fig10,
    "tvcg-fig11": tvcg_fig11,
    "glass-teapot": glass_teapot,
    "glass-bunny": glass_bunny,
    "caustics-point": caustics_point,
    "caustics-spot": caustics_spot,
    "caustics-directional": caustics_directional,
    "caustics-bunny": caustics_bunny,
    "caustics-ring": caustics_ring,
    "caustics-pool": caustics_pool,
    "caustics-prism": caustics_prism,
    "caustics-two-lights": caustics_two_lights,
}
PRESETS.update(PER_VERTEX_PRESETS)  # mirrors and lenses of Kakimoto et al. (presets_per_vertex.py)
PRESETS.update(IMPOSTOR_PRESETS)  # Hu and Qin's impostor figures (presets_impostors.py)
PRESETS.update(TRANSPORT_PRESETS)  # the light transport table of Iwasaki et al. (presets_transport.py)


def preset_names() -> list[str]:
    """Names of the built-in scenes, sorted."""
    return sorted(PRESETS)
