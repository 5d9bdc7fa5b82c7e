"""A small light's penumbra, exact: lights are sampled from at least discretize.MIN_LIGHT_PIECES
pieces, and the split stays bounded where lights are large or many.

A square light of half-width L faces down at height H over a black-backed floor of reflectance
rho; a square black blocker of half-width b, parallel to it, hangs at H / 2 over the centre.
From a floor point p, the blocker hides the square of half-width 2 b centred at -p (similar
triangles) on the light's plane, so the floor's colour is exactly

    B(p) = rho * E * (F(p -> light) - F(p -> light within that square))

with F from a point to a parallel rectangle by Howell's B-3 over its four corners (signed).
Nothing else reflects (the light and the blocker are black, the floor is flat), so there is no
other bounce. With L > 2 b there is no umbra; the penumbra is where |x|, |y| < L + 2 b (1,014
of the floor's 21,600 corners), where the errors are measured.
"""

import numpy as np
import pytest

from core import Scene, bake
from core.mesh.discretize import BLACK_LIGHT_PIECES, MAX_EMITTER_SHARE, discretize
from core.mesh.discretize import MIN_LIGHT_PIECES
from core.scene.lights import AreaLight, area_light
from core.transport.direct import MAX_ADDED_LIGHT_PIECES, DirectLighting
from core.transport.analytic import point_to_triangle
from core.transport.formfactors import FormFactorEngine
from core.transport.raycast import RayCaster
from core.rays.visibility import Visibility
from core.util.geometry import areas_and_normals
from tests.core.scenes import box, grid, merge, quad

HEIGHT, LIGHT, BLOCKER, FLOOR = 2.0, 0.25, 0.1, 2.0  # half-widths
RHO, RADIANCE = 0.5, 10.0
# a light of 2 triangles, one patch each, is split ceil(sqrt(MIN_LIGHT_PIECES / 2)) times per edge
SQUARE_SPLIT = 2 * int(np.ceil(np.sqrt(MIN_LIGHT_PIECES / 2))) ** 2  # 18


def corner_factor(x, y, height):
    """Howell B-3: a point under a corner of an x by y rectangle at ``height``, facing it."""
    x, y = np.abs(x) / height, np.abs(y) / height
    sx, sy = np.sqrt(1 + x * x), np.sqrt(1 + y * y)
    return (x / sx * np.arctan(y / sx) + y / sy * np.arctan(x / sy)) / (2 * np.pi)


def rectangle_factor(px, py, x0, x1, y0, y1, height):
    """F from points (px, py, 0) facing up to the rectangles [x0, x1] x [y0, y1] at ``height``
    (0 where empty), by superposition of corner rectangles."""
    def signed(x, y):
        return np.sign(x - px) * np.sign(y - py) * corner_factor(x - px, y - py, height)

    value = signed(x1, y1) - signed(x0, y1) - signed(x1, y0) + signed(x0, y0)
    return np.where((x1 > x0) & (y1 > y0), value, 0.0)


def exact_floor(points):
    px, py = points[..., 0], points[..., 1]
    whole = rectangle_factor(px, py, -LIGHT, LIGHT, -LIGHT, LIGHT, HEIGHT)
    s = 2 * BLOCKER
    hidden = rectangle_factor(px, py, np.maximum(-LIGHT, -px - s), np.minimum(LIGHT, -px + s),
                              np.maximum(-LIGHT, -py - s), np.minimum(LIGHT, -py + s), HEIGHT)
    return RHO * RADIANCE * (whole - hidden)


def light_quad():
    return quad([-LIGHT, -LIGHT, HEIGHT], [0, 2 * LIGHT, 0], [2 * LIGHT, 0, 0])  # faces down


def penumbra_scene(light_as_mesh: bool) -> tuple[Scene, int]:
    floor = grid([-FLOOR, -FLOOR, 0], [2 * FLOOR, 0, 0], [0, 2 * FLOOR, 0], 60)  # faces up
    blocker = quad([-BLOCKER, -BLOCKER, HEIGHT / 2], [0, 2 * BLOCKER, 0], [2 * BLOCKER, 0, 0])
    parts = [floor, blocker] + ([light_quad()] if light_as_mesh else [])
    vertices, triangles = merge(*parts)
    count, floor_count = len(triangles), len(floor[1])
    reflectance = np.zeros((count, 3))
    reflectance[:floor_count] = RHO
    emission = np.zeros((count, 3))
    lights = ()
    if light_as_mesh:
        emission[-2:] = RADIANCE
    else:
        vertices_l, triangles_l = light_quad()
        lights = (AreaLight(vertices_l[triangles_l], np.full(3, RADIANCE * np.pi * (2 * LIGHT) ** 2)),)
    scene = Scene(vertices, triangles, reflectance, emission, two_sided=np.zeros(count, bool), lights=lights)
    return scene, floor_count


@pytest.mark.parametrize("light_as_mesh, patch_size, rms_tolerance, max_tolerance", [
    # 18 patches, each read by the floor's nodes at two sets of 9 stratified points and, where
    # either disagrees, 36 more (``raycast.joined_shares``); measured 0.53 % RMS, 1.6 % at worst
    # (over seeds 0 to 5: 0.45 % RMS; with 16 rays a patch, 4 probes first, where a shadow's edge
    # crossing between the probes is missed: 1.34 % and 3.9 %, 1.54 % over the seeds; in 2
    # patches, as the patch size asks: 6.9 % and 41 %)
    (True, 1.0, 0.012, 0.035),
    # the patch size would make the black light 128 patches: it is split into 18 all the same
    # (measured 0.53 % RMS, 1.6 % at worst; with 16 rays a patch, probed, 1.53 % and 4.9 %)
    (True, 0.1, 0.012, 0.035),
    # 18 pieces read as the emitting patches above: measured 0.44 % RMS, 1.5 % at worst (with 16
    # rays a piece, every ray cast: 0.74 % and 1.9 %; in its 2 triangles: 3.7 % and 11 %)
    (False, 1.0, 0.009, 0.026),
])
def test_a_small_light_casts_its_exact_penumbra(light_as_mesh, patch_size, rms_tolerance, max_tolerance):
    scene, floor_count = penumbra_scene(light_as_mesh)
    result = bake(scene, patch_size=patch_size)  # the light is 0.5 wide: at 1.0 one patch per triangle
    corners = scene.vertices[scene.triangles[:floor_count]]
    penumbra = (np.abs(corners[..., :2]) < LIGHT + 2 * BLOCKER).all(axis=-1)
    truth = exact_floor(corners)[penumbra]
    error = result.corner_colors[:floor_count, :, 0][penumbra] - truth
    assert np.sqrt(np.mean(error**2)) <= rms_tolerance * truth.mean()
    assert np.abs(error).max() <= max_tolerance * truth.max()


def test_a_small_emitter_is_split_into_enough_patches_a_large_one_is_not():
    floor = quad([-2, -2, 0], [4, 0, 0], [0, 4, 0])  # 2 x 36 patches at this size
    panel = quad([-2, -2, 3], [0, 4, 0], [4, 0, 0])  # faces down, 2 x 36 patches: large enough
    vertices, triangles = merge(floor, panel, light_quad())  # the light: 2 triangles, 1 patch each
    emission = np.zeros((6, 3))
    emission[2:] = 1.0
    mesh = discretize(Scene(vertices, triangles, np.full((6, 3), 0.5), emission), patch_size=1.0)
    patches = np.bincount(mesh.patch_triangle, minlength=6)
    np.testing.assert_array_equal(patches, [36, 36, 36, 36, SQUARE_SPLIT // 2, SQUARE_SPLIT // 2])


def test_a_black_emitter_is_split_into_about_black_light_pieces_a_reflecting_one_as_the_patch_size_asks():
    """A 4 x 4 emitting panel of 2 triangles, whose diagonal (5.7) the patch size 0.25 divides 23
    times: 2 x 23^2 = 1,058 patches. Black, it is split ceil(23 sqrt(8 / 1,058)) = 2 times per edge,
    into 8 patches, the fewest of its split into squares of at least BLACK_LIGHT_PIECES; reflecting,
    its patches show the light it reflects and it keeps them."""
    floor = quad([-2, -2, 0], [4, 0, 0], [0, 4, 0])
    panel = quad([-2, -2, 3], [0, 4, 0], [4, 0, 0])  # faces down
    vertices, triangles = merge(floor, panel)
    emission = np.zeros((4, 3))
    emission[2:] = 1.0
    for panel_reflectance, panel_patches in ((0.0, 2 * 2**2), (0.5, 2 * 23**2)):
        reflectance = np.full((4, 3), 0.5)
        reflectance[2:] = panel_reflectance
        mesh = discretize(Scene(vertices, triangles, reflectance, emission), patch_size=0.25)
        patches = np.bincount(mesh.patch_triangle, minlength=4)
        assert patches[2:].sum() == panel_patches >= BLACK_LIGHT_PIECES
        np.testing.assert_array_equal(patches[:2], [23**2, 23**2])


def small_lights(count: int) -> tuple[Scene, int]:
    """``count`` separate lights of 2 triangles over a floor; the floor's patches at size 1."""
    floor = quad([-10, -10, 0], [20, 0, 0], [0, 20, 0])
    lights = [quad([x, 0, 1], [0, 0.1, 0], [0.1, 0, 0]) for x in np.linspace(-9, 9, count)]
    vertices, triangles = merge(floor, *lights)
    emission = np.zeros((len(triangles), 3))
    emission[2:] = 1.0
    floor_patches = 2 * 29**2  # its diagonal, 28.3, in 29 divisions
    return Scene(vertices, triangles, np.full((len(triangles), 3), 0.5), emission), floor_patches


def test_many_small_emitters_are_split_within_a_bound():
    """Each light would grow from 2 patches to 18; the lights so split may be MAX_EMITTER_SHARE of
    the patches: the most lights that fit are split, one more and none is."""
    _, floor_patches = small_lights(1)
    fits = int(MAX_EMITTER_SHARE * floor_patches / ((1 - MAX_EMITTER_SHARE) * SQUARE_SPLIT))
    scene, _ = small_lights(fits)
    assert discretize(scene, patch_size=1.0).patch_count == floor_patches + fits * SQUARE_SPLIT
    scene, _ = small_lights(fits + 1)
    assert discretize(scene, patch_size=1.0).patch_count == floor_patches + (fits + 1) * 2


def test_area_lights_are_split_within_a_bound():
    vertices, triangles = light_quad()
    square = AreaLight(vertices[triangles], np.ones(3))
    visibility = Visibility(vertices[triangles])
    fits = MAX_ADDED_LIGHT_PIECES // (SQUARE_SPLIT - 2)
    assert DirectLighting((square,) * fits, np.zeros(3), visibility, 16, 0).light_pieces == fits * SQUARE_SPLIT
    assert DirectLighting((square,) * (fits + 1), np.zeros(3), visibility, 16, 0).light_pieces == (fits + 1) * 2
    # a disk light is a fan of enough triangles already: it adds nothing, and the square is split
    disk = area_light("DISK", 0.5, 0.5, np.eye(4), np.ones(3))
    assert len(disk.triangles) >= MIN_LIGHT_PIECES
    lights = (disk,) * 20 + (square,)
    pieces = DirectLighting(lights, np.zeros(3), visibility, 16, 0).light_pieces
    assert pieces == 20 * len(disk.triangles) + SQUARE_SPLIT


def _close_under_a_half_hidden_emitter(edge: float, emitting: bool, seed: int, height: float = 1.0,
                                       finely: bool = False, rays: int = 4) -> tuple[float, float, float]:
    """A point at the origin facing up, a 2 x 2 emitting square (2 triangles, one patch each)
    facing down at ``height`` and a blocker at half the height over x > edge / 2, which hides
    exactly the emitter's part x > edge (similar triangles): the ray-cast form factor at ``rays``
    rays per form factor (with the close sampling of emitters or without; ``finely``: as a node),
    the exact one (B-3 of the part left, as two triangles) and the whole square's."""
    emitter = quad([-1, -1, height], [0, 2, 0], [2, 0, 0])  # faces down
    blocker = quad([edge / 2, -2, height / 2], [0, 4, 0], [2, 0, 0])
    vertices, triangles = merge(emitter, blocker)
    corners = vertices[triangles]
    normals = np.tile([0.0, 0.0, -1.0], (2, 1))
    caster = RayCaster(corners[:2], normals, np.full(2, 2.0), Visibility(corners), rays, seed,
                       patch_owners=np.arange(2), probing=True, emitting=np.ones(2, dtype=bool) if emitting else None)
    seen = caster.form_factors(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), np.zeros(2, dtype=np.int64),
                               np.arange(2), np.array([finely])).sum()
    up = np.tile([0.0, 0.0, 1.0], (2, 1))
    visible = quad([-1, -1, height], [0, 2, 0], [1 + edge, 0, 0])
    exact = point_to_triangle(np.zeros((2, 3)), up, visible[0][visible[1]]).sum()
    return seen, exact, point_to_triangle(np.zeros((2, 3)), up, corners[:2]).sum()


@pytest.mark.parametrize("height", [1.0, 0.2, 0.05])
@pytest.mark.parametrize("finely, bound", [(True, 0.02), (False, 0.045)])
def test_an_emitter_close_by_is_sampled_finely_enough_for_a_shadow_edge(height, finely, bound):
    """An emitter seen from within CLOSE_REACH of its size gets directions uniform in its solid
    angle, all cast, where 4 samples (the probes) decide a far one: CLOSE_RAYS (16), and from a
    point asked about finely (a node) two such sets and CLOSE_MIXED_RAYS (128) more where either
    disagrees (``raycast.joined_shares``). A
    straight shadow edge crosses about n of a triangle's n x n strata, each seen or not: about
    sqrt(n) / n^2 of the triangle's share, half that of the whole square's form factor (6 % at n =
    4) at worst; measured RMS over three edges and eight seeds, at heights 1, 0.2 and 0.05: finely
    0.83, 0.34 and 0.26 % (16 alone, as below, 3.0, 1.7 and 0.75 %; 128 everywhere 0.57, 0.28 and
    0.14 %; 64 everywhere, as before the sets were joined by more, 1.14, 0.53 and 0.17 %;
    samples uniform in area, weighted by the kernel, read 1.6, 4.0 and 9.9 % from 64: so close, the
    few samples under the point weigh for all), else 3.0, 1.7 and 0.75 % (bound 4.5 %), against 9
    to 29 % with 4 samples per patch."""
    errors = {True: [], False: []}
    for edge in (-0.43, 0.13, 0.52):
        for seed in range(8):
            for emitting in (True, False):
                seen, exact, whole = _close_under_a_half_hidden_emitter(edge, emitting, seed, height, finely)
                errors[emitting].append((seen - exact) / whole)
    assert np.sqrt(np.mean(np.square(errors[True]))) < bound
    assert np.sqrt(np.mean(np.square(errors[False]))) > 0.04  # the case needs the close sampling


def test_more_rays_per_form_factor_read_a_close_emitter_with_as_many_directions():
    """Close by, an emitter is read by directions in its solid angle, as many as the bake's rays
    per form factor where those are more than CLOSE_RAYS: at 64 rays a patch (not asked about
    finely) measured RMS over three edges and eight seeds, at heights 1, 0.2 and 0.05, 1.14, 0.53
    and 0.17 % (as at 16 rays: 3.0, 1.7 and 0.75 %; 64 samples uniform in area, 4 x 4 probes first,
    as before 64 rays went in the solid angle: 2.2, 5.6 and 11 %). Bound 1.5 %."""
    for height in (1.0, 0.2, 0.05):
        errors = [(seen - exact) / whole for seen, exact, whole in (
            _close_under_a_half_hidden_emitter(edge, True, seed, height, finely=False, rays=64)
            for edge in (-0.43, 0.13, 0.52) for seed in range(8))]
        assert np.sqrt(np.mean(np.square(errors))) < 0.015


@pytest.mark.parametrize("height", [1.0, 0.2, 0.05])
def test_an_area_light_close_by_is_read_as_an_emitting_patch_is(height):
    """An area light (not geometry: Blender's Area light) is read at the nodes as an emitting patch
    is, in its solid angle close by and with more rays where its first sets disagree: the 2 x 2
    light over a point facing up, half hidden as in ``_close_under_a_half_hidden_emitter``, split
    into its pieces (``MIN_LIGHT_PIECES``), G against the exact F / (pi A). Measured RMS over three
    edges and eight seeds, of the whole light's G, at heights 1, 0.2 and 0.05: 0.38, 0.34 and
    0.21 % (1.3 % at worst), where 16 samples of each piece uniform in area, weighted by the
    kernel, all cast, read 0.91, 3.4 and 4.1 % (12 % at worst). Bound 1.2 %."""
    errors = []
    for edge in (-0.43, 0.13, 0.52):
        emitter = quad([-1, -1, height], [0, 2, 0], [2, 0, 0])  # faces down
        blocker = quad([edge / 2, -2, height / 2], [0, 4, 0], [2, 0, 0])
        visible = quad([-1, -1, height], [0, 2, 0], [1 + edge, 0, 0])
        up = np.tile([0.0, 0.0, 1.0], (2, 1))
        exact, whole = (point_to_triangle(np.zeros((2, 3)), up, part[0][part[1]]).sum() / (4 * np.pi)
                        for part in (visible, emitter))
        for seed in range(8):
            lighting = DirectLighting((AreaLight(emitter[0][emitter[1]], np.ones(3)),), np.zeros(3),
                                      Visibility(blocker[0][blocker[1]]), 16, seed)
            read = lighting.factors_at(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]), lambda _fraction: None)
            errors.append((read[0, 0, 0] - exact) / whole)
    assert np.sqrt(np.mean(np.square(errors))) < 0.012


def test_the_nodes_read_a_far_emitter_with_more_rays():
    """Beyond CLOSE_REACH, the points asked about finely (a bake's nodes) sample an emitting patch
    at two sets of EMITTER_RAYS (9) stratified points, all cast, and EMITTER_MIXED_RAYS (36) more
    where either disagrees, where the probes (4) decide for the other points: a shadow edge
    crosses about 6 of a triangle's 6 x 6 strata, sqrt(6) / 36 of its share, 3.4 % of the square's
    form factor at worst; measured RMS over three edges and eight seeds at height 4: 2.5 % (36
    everywhere 2.3 %, 9 alone 5.1 %), against 8 % with the probes. Bound 3.5 %."""
    errors = {True: [], False: []}
    for edge in (-0.43, 0.13, 0.52):
        for seed in range(8):
            for finely in (True, False):
                seen, exact, whole = _close_under_a_half_hidden_emitter(edge, True, seed, 4.0, finely)
                errors[finely].append((seen - exact) / whole)
    assert np.sqrt(np.mean(np.square(errors[True]))) < 0.035
    assert np.sqrt(np.mean(np.square(errors[False]))) > 0.06


@pytest.mark.parametrize("rays", [16, 64])
def test_the_nodes_keep_a_thin_bars_shadow_under_a_far_emitter_on_average(rays):
    """A bar 1 cm wide at height 1 under a 0.6 m emitting square at height 2 hides, from a floor
    point p, the strip |x + p_x| < 1 cm of the square (similar triangles): 3.4 % of its form
    factor, exactly (``rectangle_factor``). The nodes' two first sets decide for each other where
    the more samples are cast (``joined_shares``), so on average over 48 seeds they keep the shadow,
    at any rays per form factor: the share of it lost, measured over 192 seeds, 0.004 +- 0.022 at
    16 rays and 0.008 +- 0.022 at 64 (one seed's spread 0.3; bound 0.2, about 4.5 standard errors
    of 48 seeds, 0.3 / sqrt(48)). The probes deciding for the rest (16 of 64, as the nodes read far
    emitters from 36 rays on before; 4 of 16, as the patches still do) lost 0.68 and 0.92 of it.
    The bar's triangles are patches too, before the emitter's, so that an emitter's samples are
    looked up by its own index among the emitters, not by its patch's."""
    bar = quad([-0.005, -5, 1.0], [0, 10, 0], [0.01, 0, 0])
    emitter = quad([-0.3, -0.3, 2.0], [0, 0.6, 0], [0.6, 0, 0])  # faces down
    vertices, triangles = merge(bar, emitter)
    corners = vertices[triangles]
    areas, normals = areas_and_normals(corners)
    x = np.linspace(-0.03, 0.03, 7)
    points, up = np.c_[x, np.zeros((7, 2))], np.tile([0.0, 0.0, 1.0], (7, 1))
    whole = rectangle_factor(x, 0.0, -0.3, 0.3, -0.3, 0.3, 2.0)
    seen = whole - rectangle_factor(x, 0.0, np.maximum(-0.3, -x - 0.01), np.minimum(0.3, -x + 0.01), -0.3, 0.3, 2.0)
    receivers, sources = np.repeat(np.arange(7), 2), np.tile([2, 3], 7)
    lost = {}
    for finely in (True, False):
        readings = [RayCaster(corners, normals, areas, Visibility(corners), rays, seed, patch_owners=np.arange(4),
                              probing=True, emitting=np.arange(4) >= 2).form_factors(
            points, up, receivers, sources, np.full(7, finely)).reshape(7, 2).sum(axis=1) for seed in range(48)]
        lost[finely] = np.mean((np.mean(readings, axis=0) - seen) / (whole - seen))
    assert abs(lost[True]) < 0.2
    assert lost[False] > 0.5  # the case needs the two sets


def test_every_shot_of_an_emitting_ceiling_lands_whole_in_a_closed_box():
    """A closed cube whose ceiling emits: each of its patches' light lands on the others, so
    sum_p A_p F(p -> s) = A_s F(s -> all) = A_s for every emitting patch s (reciprocity). The
    patches beside the ceiling are larger than their distance to it, and their light is far from
    linear: read at their centroids, the sums were 0.95 to 1.044 (18 patches, four seeds, patch
    size 0.34); as the mean of MEAN_POINTS points (``formfactors.MEAN_REACH``, a Monte Carlo
    bake's) 0.984 to 1.017. Bound 2 %."""
    vertices, triangles = box(1.0)
    emission = np.zeros((len(triangles), 3))
    emission[2:4] = 1.0  # the ceiling
    reflectance = np.where(emission > 0, 0.0, 0.5)
    mesh = discretize(Scene(vertices, triangles, reflectance, emission), patch_size=0.34)
    emitters = np.flatnonzero(mesh.patch_emission.any(axis=1))
    sums = []
    for seed in range(4):
        engine = FormFactorEngine(mesh, "raycast", rays_per_form_factor=4, seed=seed, light_means=True)
        columns, _ = engine.shooting_columns(emitters)
        for source, column in zip(emitters, columns):
            assert isinstance(column, np.ndarray)  # (fewer receivers than REACH_RECEIVERS)
            sums.append((column[: mesh.patch_count] * mesh.patch_areas).sum() / mesh.patch_areas[source])
    np.testing.assert_allclose(sums, 1.0, atol=0.02)
