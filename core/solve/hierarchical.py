"""Hierarchical radiosity with clustering (Hanrahan, Salzman and Aupperle 1991; Smits, Arvo and
Greenberg 1994; Sillion 1995): light moves along links between nodes of the hierarchy
(``mesh.hierarchy``), as fine as the light they carry needs, so the cost grows with the light and
not with the square of the patches.

Refinement (BF refinement): a candidate link (receiver r, source s) carries about
rho_r F B_s, F the unoccluded form factor bounded from the nodes' bounding spheres. It is split,
the larger node into its two children, while that is above ``threshold`` times the mean
radiosity of the surfaces that do not emit, or while the nodes are too close for a cluster's
view of the other to hold; two patches (or a point and a patch) are linked with their exact form
factor; a cluster link that is partly visible and carries more than PARTIAL of the threshold is
split too (its shadow's edge). Candidates are processed in rounds of bounded blocks, from the
root's link with itself.

Solving: a Jacobi iteration over the links, each gathering K B_s into its receiver, then
push-pull: what a node gathered is pushed down to its patches (a flat node's as it is; a cluster
that is not flat gathers the light's directions in spherical harmonics of order 2, which each
patch reads with its own normal: Ramamoorthi and Hanrahan 2001), each patch's radiosity is
E + rho (direct + gathered), and clusters take their patches' area-weighted mean (pull). In a
closed scene each receiver's form factors are made to sum to 1 by its approximate links alone
(``energy_factors``). The links are refined again from the solved radiosity with the final
threshold (multigridding), and solved again from where they were.

The receiver nodes (vertex colours) gather from the converged hierarchy through links of their
own, refined the same way by the light arriving (``point_receivers``): exact form factors near
them, clusters far away (``point_light``).

Never chosen automatically: on the benchmarks it is slower for its error than progressive
refinement on small scenes and than Monte Carlo on large ones (docs/methods.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..mesh.hierarchy import Hierarchy, build
from ..mesh.refine import radiosity_scale
from ..transport.arriving import ArrivingLight
from ..transport.links import (VISIBILITY_RAYS, averaged_coefficients, cluster_coefficients, enclosed, sample_points,
                               seen_share)
from ..util import parallel, streams
from ..util.progress import Report, Stages, effort

# A link carrying less than this share of the threshold is not split for being partly visible.
PARTIAL = 0.25
# The first refinement stops at this times the final threshold, before the first solve.
COARSE = 4.0
# Nodes are too close for a cluster link unless their centres are this many times the sum of their
# radii apart.
SEPARATION = 0.0
# Flat nodes whose planes are this share of their size apart, facing one way, are in one plane.
COPLANAR = 1e-6
PAIRS_PER_BLOCK = 1 << 15
# Bytes a link or a candidate takes while the links are refined (indices, coefficient, direction).
BYTES_PER_LINK = 64
# Ratios of successive changes that agree within this have settled on the slowest mode.
SETTLED = 0.005
MAX_ITERATIONS = 500
# Irradiance convolution of spherical harmonics of orders 0, 1 and 2 (the clamped cosine's).
SH_CONVOLUTION = np.array([np.pi, 2 * np.pi / 3, 2 * np.pi / 3, 2 * np.pi / 3, np.pi / 4, np.pi / 4, np.pi / 4,
                           np.pi / 4, np.pi / 4])


@dataclass
class Links:
    """Links from node ``source`` to ``receiver`` (n,) each: G_receiver += coefficient B_source.
    ``direction`` (n, 3): where the light comes from, for receivers that are not flat (whose
    coefficient leaves out the cosine); zero for the others."""

    receiver: np.ndarray
    source: np.ndarray
    coefficient: np.ndarray
    direction: np.ndarray

    @staticmethod
    def joined(parts: list[Links]) -> Links:
        if not parts:
            return Links(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3)))
        return Links(*(np.concatenate([getattr(part, name) for part in parts])
                       for name in ("receiver", "source", "coefficient", "direction")))

    def __len__(self) -> int:
        return len(self.receiver)

    def __getitem__(self, chosen) -> Links:
        return Links(self.receiver[chosen], self.source[chosen], self.coefficient[chosen], self.direction[chosen])


@dataclass
class Receivers:
    """What the oracle reads of the receivers (n of them): tree nodes, or points.

    center, radius, normal (n, 3; zero where not flat), plane (n,) n . centroid, reflectance (n,)
    the largest channel, splittable (n,) bool; for the exact form factors to patches: the
    receiving point and normal of each (n, 3) and whether it has one (a patch, or a point)."""

    center: np.ndarray
    radius: np.ndarray
    normal: np.ndarray
    plane: np.ndarray
    reflectance: np.ndarray
    splittable: np.ndarray
    exact: np.ndarray
    point: np.ndarray
    point_normal: np.ndarray
    area: np.ndarray
    typical_area: float


def tree_receivers(hierarchy: Hierarchy, light: ArrivingLight) -> Receivers:
    mesh, count = light.mesh, hierarchy.leaf_count
    nodes = np.arange(hierarchy.node_count)
    normal = np.where(hierarchy.flat[:, None], hierarchy.normal(nodes), 0.0)
    point, point_normal = np.zeros((len(nodes), 3)), np.zeros((len(nodes), 3))
    point[:count] = light.engine.receiving_points[hierarchy.patch]
    point_normal[:count] = mesh.patch_normals[hierarchy.patch]
    return Receivers(hierarchy.center, hierarchy.radius, normal, np.einsum("kx,kx->k", normal, hierarchy.centroid),
                     hierarchy.reflectance.max(axis=1), hierarchy.left >= 0, nodes < count, point, point_normal,
                     hierarchy.area, float(hierarchy.area[:count].mean()))


def point_receivers(points: np.ndarray, normals: np.ndarray) -> Receivers:
    """The points where colours are read, as receivers of reflectance 1: what arrives there is a
    result of its own (``BakeResult.corner_lighting``, the add-on's Lighting output), whatever the
    surface reflects of it (in a room of black walls their links were never split)."""
    count = len(points)
    return Receivers(points, np.zeros(count), normals, np.einsum("kx,kx->k", normals, points), np.ones(count),
                     np.zeros(count, dtype=bool), np.ones(count, dtype=bool), points, normals, np.ones(count), 1.0)


class Refiner:
    """Links from the hierarchy's nodes to ``receivers`` (tree nodes when ``tree``, else points),
    refined against the radiosity ``radiosity`` (H, C) of the nodes."""

    def __init__(self, hierarchy: Hierarchy, light: ArrivingLight, receivers: Receivers, tree: bool, seed: int,
                 memory_budget: int):
        self.hierarchy, self.light, self.receivers, self.tree, self.seed = hierarchy, light, receivers, tree, seed
        self.most_links = memory_budget // BYTES_PER_LINK
        self.rounds = 0

    def refine(self, candidates: tuple[np.ndarray, np.ndarray], radiosity: np.ndarray, threshold: float,
               report: Report) -> Links:
        """The accepted links from ``candidates`` (receivers, sources) and what splitting them
        makes, for links carrying more than ``threshold`` (absolute, in radiosity)."""
        brightness = radiosity.max(axis=1)
        accepted, pending, done = [], [candidates], 0
        while pending:
            waiting = sum(len(part[0]) for part in pending) + sum(len(part) for part in accepted)
            if waiting > self.most_links:
                raise ValueError(
                    f"hierarchical radiosity would need more than {waiting:,} links, over the memory budget of "
                    f"{self.most_links * BYTES_PER_LINK / 2**30:.2f} GiB; raise link_tolerance or memory_budget, "
                    "or use solver='progressive'")
            receivers, sources = (np.concatenate(part) for part in zip(*pending))
            pending = []
            starts = range(0, len(receivers), PAIRS_PER_BLOCK)
            blocks = [(receivers[start:start + PAIRS_PER_BLOCK], sources[start:start + PAIRS_PER_BLOCK], start)
                      for start in starts]
            for links, split in parallel.map_ordered(lambda block: self._block(*block, brightness, threshold), blocks):
                accepted.append(links)
                if len(split[0]):
                    pending.append(split)
            self.rounds += 1
            done += 1
            report(min(done / 40, 0.99), f"links: {sum(len(part) for part in accepted):,}")
        return Links.joined(accepted)

    def _block(self, receivers, sources, start, brightness, threshold) -> tuple[Links, tuple[np.ndarray, np.ndarray]]:
        """The links accepted among candidates (receivers, sources) (k,) each, and the candidates
        their splitting makes."""
        h, rx = self.hierarchy, self.receivers
        split = []
        if self.tree:  # a node's link with itself: the links among its children
            itself = receivers == sources
            node = receivers[itself]
            node = node[h.left[node] >= 0]
            kids = np.stack([h.left[node], h.right[node]], axis=1)
            split.append((np.repeat(kids, 2, axis=1).reshape(-1), np.tile(kids, (1, 2)).reshape(-1)))
            receivers, sources = receivers[~itself], sources[~itself]
        # nothing passes between a node and one wholly behind the other's plane
        s_normal = np.where(h.flat[sources, None], h.normal(sources), 0.0)
        s_plane = np.einsum("kx,kx->k", s_normal, h.centroid[sources])
        r_behind = np.einsum("kx,kx->k", s_normal, rx.center[receivers]) - s_plane < -rx.radius[receivers]
        s_behind = np.einsum("kx,kx->k", rx.normal[receivers], h.center[sources]) - rx.plane[receivers] \
            < -h.radius[sources]
        r_flat = np.any(rx.normal[receivers] != 0, axis=1)
        # flat nodes in one plane facing one way exchange nothing
        coplanar = h.flat[sources] & r_flat & (np.einsum("kx,kx->k", s_normal, rx.normal[receivers]) > 1 - 1e-9) \
            & (np.abs(rx.plane[receivers] - s_plane) <= COPLANAR * (rx.radius[receivers] + h.radius[sources]))
        keep = ~((h.flat[sources] & r_behind) | (r_flat & s_behind) | coplanar)
        receivers, sources, r_flat = receivers[keep], sources[keep], r_flat[keep]
        # a node across the other's plane is seen in part: its centre tells nothing of that part
        r_across = h.flat[sources] & (np.abs(np.einsum("kx,kx->k", s_normal[keep], rx.center[receivers])
                                             - s_plane[keep]) < rx.radius[receivers])
        s_across = r_flat & (np.abs(np.einsum("kx,kx->k", rx.normal[receivers], h.center[sources])
                                    - rx.plane[receivers]) < h.radius[sources])
        distance = np.linalg.norm(h.center[sources] - rx.center[receivers], axis=1)
        reach = rx.radius[receivers] + h.radius[sources]
        # what the source shows in any direction is at most its area, or its bounding sphere's
        # four great circles; seen from the receiver's centre as a disc at the source's centre
        shown = np.minimum(h.area[sources], 4 * np.pi * h.radius[sources] ** 2)
        carried = rx.reflectance[receivers] * brightness[sources] * shown / (np.pi * distance * distance + shown) \
            * np.minimum(1.0, rx.area[receivers] / rx.typical_area)
        split_r, split_s = rx.splittable[receivers], h.left[sources] >= 0
        exact = rx.exact[receivers] & ~split_s
        # a node across the other's plane is seen in part, which its centre does not tell: split
        # unless it carries little, and then averaged over the rays' directions (``_cluster``)
        across = r_across | s_across
        need = ~exact & ((carried > threshold) | (distance < SEPARATION * reach)
                         | (across & (carried > PARTIAL * threshold))) & (split_r | split_s)
        links = []
        if exact.any():
            links.append(self._exact(receivers[exact], sources[exact]))
        chosen = np.flatnonzero(~exact & ~need)
        if len(chosen):
            unoccluded, visible, direction = self._cluster(receivers[chosen], sources[chosen], across[chosen], start)
            # a partly seen link carrying enough is split: its shadow's edge
            partial = (visible > 0) & (visible < 1) & (carried[chosen] > PARTIAL * threshold) \
                & (split_r[chosen] | split_s[chosen])
            need[chosen[partial]] = True
            kept, value = chosen[~partial], (unoccluded * visible)[~partial]
            # kept even when nothing was seen: a later pass, with more light, re-examines it
            links.append(Links(receivers[kept], sources[kept], value,
                               np.where(r_flat[kept][:, None], 0.0, direction[~partial])))
        # split the larger node (the receiver when the source cannot be split)
        chosen = np.flatnonzero(need)
        by_receiver = split_r[chosen] & (~split_s[chosen] | (rx.radius[receivers[chosen]] >= h.radius[sources[chosen]]))
        r_side, s_side = chosen[by_receiver], chosen[~by_receiver]
        split.append((_children(h, receivers[r_side]), np.repeat(sources[r_side], 2)))
        split.append((np.repeat(receivers[s_side], 2), _children(h, sources[s_side])))
        return Links.joined(links), tuple(np.concatenate(part) for part in zip(*split))

    def _exact(self, receivers, sources) -> Links:
        """Links from patches (leaf ``sources``) to patches or points: exact form factors."""
        rx, h = self.receivers, self.hierarchy
        factors = self.light.engine.point_form_factors(rx.point, rx.point_normal, receivers, h.patch[sources])
        seen = factors > 0
        return Links(receivers[seen], sources[seen], factors[seen], np.zeros((int(seen.sum()), 3)))

    def _cluster(self, receivers, sources, across, start) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cluster links' coefficients without visibility (k,), visibility (k,) and the
        directions the light comes from (k, 3); the links ``across`` (k,) bool average their
        coefficients over the rays' directions."""
        h, rx, mesh = self.hierarchy, self.receivers, self.light.mesh
        rng = streams.generator(self.seed, streams.LINK_RAYS, self.rounds, start)
        ends, end_normals = sample_points(h, mesh.patch_corners, mesh.patch_normals, sources, VISIBILITY_RAYS, rng)
        if self.tree:
            starts, start_normals = sample_points(h, mesh.patch_corners, mesh.patch_normals, receivers,
                                                  VISIBILITY_RAYS, rng)
        else:
            starts = np.repeat(rx.point[receivers][:, None], VISIBILITY_RAYS, axis=1)
            start_normals = np.repeat(rx.point_normal[receivers][:, None], VISIBILITY_RAYS, axis=1)
        coefficient, direction = cluster_coefficients(h, rx.center[receivers], rx.normal[receivers], sources)
        if across.any():
            coefficient[across] = averaged_coefficients(h, rx.center[receivers[across]], rx.normal[receivers[across]],
                                                        sources[across], starts[across], ends[across])
        visible = seen_share(self.light.engine.visibility, starts, start_normals, ends, end_normals)
        return coefficient, visible, direction


def _children(hierarchy: Hierarchy, nodes: np.ndarray) -> np.ndarray:
    """(2k,) the two children of each of ``nodes`` (k,), in turn."""
    return np.stack([hierarchy.left[nodes], hierarchy.right[nodes]], axis=1).reshape(-1)


def _unsorted(hierarchy: Hierarchy, radiosity: np.ndarray) -> np.ndarray:
    """(P, C) the leaves' radiosity in the patches' order."""
    result = np.empty((hierarchy.leaf_count, radiosity.shape[1]))
    result[hierarchy.patch] = radiosity[: hierarchy.leaf_count]
    return result


def _expected_scale(mesh, patch_direct: np.ndarray) -> float:
    """The mean radiosity of the surfaces that do not emit, before any is solved: the emitted and
    directly received power spread evenly, with all its bounces at the mean reflectance."""
    channels = patch_direct.shape[1]
    area, reflectance = mesh.patch_areas, mesh.patch_reflectance[:, :channels]
    power = area @ (mesh.patch_emission[:, :channels] + reflectance * patch_direct)
    mean_reflectance = area @ reflectance / area.sum()
    return max(float((power / area.sum() / (1 - mean_reflectance)).max()), np.finfo(float).tiny)


def _settled_rate(totals: list[np.ndarray], fastest: float) -> np.ndarray | None:
    """(C,) the rate at which the sweeps' total changes ``totals`` (each (C,)) shrink, once three
    successive ratios agree within SETTLED, all of one sign and below ``fastest``; else None."""
    if len(totals) < 4:
        return None
    last = np.array(totals[-4:])  # (4, C)
    if not (np.all(last > 0, axis=0) | np.all(last < 0, axis=0)).all():
        return None
    ratios = last[1:] / last[:-1]
    if np.any(ratios <= 0) or np.any(ratios >= fastest) or np.any(np.ptp(ratios, axis=0) > SETTLED):
        return None
    return ratios[-1]


def harmonics(directions: np.ndarray) -> np.ndarray:
    """(k, 9) real spherical harmonics of orders 0 to 2 at unit ``directions`` (k, 3)."""
    x, y, z = directions.T
    return np.stack([np.full_like(x, 0.282095), 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y,
                     1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z, 0.546274 * (x * x - y * y)],
                    axis=1)


def gathered(hierarchy: Hierarchy, links: Links, radiosity: np.ndarray,
             receivers: int) -> tuple[np.ndarray, np.ndarray]:
    """What each of ``receivers`` receivers gathers over ``links`` from node ``radiosity`` (H, C):
    (receivers, C) through flat links, and (receivers, 9, C) spherical-harmonic coefficients of
    the light from the other links."""
    channels = radiosity.shape[1]
    value = links.coefficient[:, None] * radiosity[links.source]  # (n, C)
    flat = ~np.any(links.direction != 0, axis=1)
    scalar = np.stack([np.bincount(links.receiver[flat], value[flat, c], receivers) for c in range(channels)], axis=1)
    harmonic = np.zeros((receivers, 9, channels))
    directional = np.flatnonzero(~flat)
    if len(directional):
        basis = harmonics(links.direction[directional])
        for c in range(channels):
            weighted = basis * value[directional, c][:, None]
            harmonic[:, :, c] = np.stack([np.bincount(links.receiver[directional], weighted[:, j], receivers)
                                          for j in range(9)], axis=1)
    return scalar, harmonic


def energy_factors(exact_total: np.ndarray, approximate_total: np.ndarray,
                   closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """(k,), (k,): what to multiply each receiver's light through its exact links (patch to patch,
    or to a point) and through its approximate ones (a cluster at either end) by, given the sums
    (k,) of their form factors. In a ``closed`` scene (no closure ray of any patch escaped) every
    receiver's form factors sum to exactly 1, which the approximations miss by a few percent (a
    furnace of reflectance 0.999 amplifies that a thousandfold): the approximate ones make up what
    the exact ones leave (the exact ones scaled to 1 only where there are none). In an open one,
    none may sum to more than 1 (the solve would not converge as rho -> 1). The exact ones are
    scaled down only where they alone sum to more than 1 (by rounding). Scaling every link alike
    let a poor approximation of black walls beside a receiver multiply the exact light of a
    source it sees (a black room's floor read 2.8 times its ceiling's light)."""
    inverse = 1.0 / np.where(exact_total > 0, exact_total, 1.0)
    exact_scale = np.where(closed & (approximate_total <= 0), inverse, np.minimum(1.0, inverse))
    room = np.maximum(1.0 - exact_total * exact_scale, 0.0)
    wanted = room if closed else np.minimum(approximate_total, room)
    approximate_scale = np.divide(wanted, approximate_total, out=np.ones_like(room), where=approximate_total > 0)
    return exact_scale, approximate_scale


def point_light(hierarchy: Hierarchy, links: Links, radiosity: np.ndarray, points: int, closed: bool) -> np.ndarray:
    """(points, C) what each point gathers over its ``links`` (reordered in place: ``_partitioned``)
    from node ``radiosity`` (H, C): the links from patches carry exact form factors, those from
    clusters approximations, each scaled by their ``energy_factors``."""
    parts = _partitioned(links, links.source < hierarchy.leaf_count)
    totals = [np.bincount(part.receiver, part.coefficient, points) for part in parts]
    return sum(gathered(hierarchy, part, radiosity, points)[0] * scale[:, None]  # points are flat: no directions
               for part, scale in zip(parts, energy_factors(*totals, closed)))


def _partitioned(links: Links, exact: np.ndarray) -> list[Links]:
    """``links`` reordered in place, those where ``exact`` (n,) bool first (in their order), and
    the two parts as views of it: a copy of each part would double the links' memory."""
    order = np.argsort(~exact, kind="stable")
    for values in (links.receiver, links.source, links.coefficient, links.direction):
        values[:] = values[order]
    count = int(np.count_nonzero(exact))
    return [links[:count], links[count:]]


class Solver:
    """Jacobi iterations with push-pull over the hierarchy's links."""

    def __init__(self, hierarchy: Hierarchy, light: ArrivingLight, leaf_direct: np.ndarray, seed: int):
        mesh, self.hierarchy = light.mesh, hierarchy
        channels = light.channels
        self.emission = mesh.patch_emission[hierarchy.patch, :channels]
        self.reflectance = mesh.patch_reflectance[hierarchy.patch, :channels]
        self.direct = leaf_direct
        self.leaf_basis = harmonics(mesh.patch_normals[hierarchy.patch]) * SH_CONVOLUTION
        self.levels = hierarchy.by_depth()
        self.closed = bool(enclosed(light.engine.visibility, light.engine.receiving_points[hierarchy.patch],
                                    mesh.patch_normals[hierarchy.patch],
                                    streams.generator(seed, streams.CLOSURE_RAYS)).all())
        self.parts: list[tuple[Links, np.ndarray]] = []

    def link(self, links: Links) -> None:
        """Take ``links`` for the next sweeps (reordered in place: ``_partitioned``): the exact
        ones (patch to patch) apart from the approximate ones, each with the ``energy_factors`` of
        their form factors' sums per leaf."""
        h = self.hierarchy
        parts = _partitioned(links, (links.source < h.leaf_count) & (links.receiver < h.leaf_count))
        ones = np.ones((h.node_count, 1))
        totals = [self._gathered(part, ones)[:, 0] for part in parts]
        self.parts = [(part, scale[:, None]) for part, scale in zip(parts, energy_factors(*totals, self.closed))]

    def start(self) -> np.ndarray:
        """Node radiosity (H, C) of emission and direct light alone."""
        return self.pulled(self.emission + self.reflectance * self.direct)

    def pulled(self, leaf_radiosity: np.ndarray) -> np.ndarray:
        """(H, C) node radiosity: the leaves', and each cluster the area-weighted mean of its children."""
        h = self.hierarchy
        radiosity = np.zeros((h.node_count, leaf_radiosity.shape[1]))
        radiosity[: h.leaf_count] = leaf_radiosity
        weighted = radiosity * h.area[:, None]
        for nodes in reversed(self.levels):
            weighted[nodes] = weighted[h.left[nodes]] + weighted[h.right[nodes]]
        internal = h.leaf_count
        radiosity[internal:] = weighted[internal:] / np.maximum(h.area[internal:], np.finfo(float).tiny)[:, None]
        return radiosity

    def leaf_light(self, radiosity: np.ndarray) -> np.ndarray:
        """(P, C) the light G each leaf gathers from node ``radiosity`` (H, C) through the links
        taken (``link``), each part scaled by its energy factors."""
        return sum(self._gathered(part, radiosity) * scale for part, scale in self.parts)

    def _gathered(self, links: Links, radiosity: np.ndarray) -> np.ndarray:
        """(P, C) the light each leaf gathers through ``links``, its ancestors' pushed down."""
        h = self.hierarchy
        scalar, harmonic = gathered(h, links, radiosity, h.node_count)
        for nodes in self.levels:  # root first
            for child in (h.left[nodes], h.right[nodes]):
                scalar[child] += scalar[nodes]
                harmonic[child] += harmonic[nodes]
        leaves = h.leaf_count
        return scalar[:leaves] + np.maximum(np.einsum("pj,pjc->pc", self.leaf_basis, harmonic[:leaves]), 0.0)

    def iterate(self, radiosity: np.ndarray, tolerance: float, report: Report) -> tuple[np.ndarray, dict]:
        """Jacobi sweeps from ``radiosity`` (H, C) until what is left to come, estimated from the
        last change and the rate r at which changes shrink (the sum of the changes still to come,
        r / (1 - r) times the last), is at most ``tolerance`` of the largest radiosity; the result
        and what it measured. Once the rate has settled, that remainder is added at once (Aitken's
        extrapolation of the slowest mode, as the ambient term of progressive refinement), so that
        a scene of reflectance near 1 does not take thousands of sweeps."""
        leaves, area = self.hierarchy.leaf_count, self.hierarchy.area[: self.hierarchy.leaf_count]
        # the changes shrink at most as fast as the largest reflectance times the largest form-factor sum
        fastest = float(self.reflectance.max())
        left, iterations, totals = np.inf, 0, []
        while iterations < MAX_ITERATIONS:
            leaf = self.emission + self.reflectance * (self.direct + self.leaf_light(radiosity))
            change = leaf - radiosity[:leaves]
            totals.append(area @ change)  # (C,) signed
            rate = _settled_rate(totals, fastest)
            ahead = rate / (1 - rate) if rate is not None else fastest / (1 - fastest) * np.ones_like(totals[-1])
            if rate is not None:
                leaf = leaf + change * ahead
                totals.clear()
            radiosity = self.pulled(leaf)
            scale = max(float(np.abs(radiosity).max()), np.finfo(float).tiny)
            left = float(np.abs(change * (1 + ahead)).max()) / scale
            iterations += 1
            report(effort(left, tolerance), f"{iterations} sweeps, {left:.2g} left")
            if left <= tolerance and rate is None:
                break
        return radiosity, {"iterations": iterations, "converged": left <= tolerance, "error_bound": left}


def solve(light: ArrivingLight, patch_direct: np.ndarray, node_direct: np.ndarray, settings, stages: Stages):
    """Patch radiosity (P, C), the light at the receiver nodes (N, C) and statistics, by
    hierarchical radiosity (module docstring)."""
    mesh = light.mesh
    hierarchy = stages.run("hierarchy", (0.0, 0.05), lambda _report: build(mesh), timer="hierarchy")
    solver = Solver(hierarchy, light, patch_direct[hierarchy.patch], settings.seed)
    radiosity = solver.start()
    expected = _expected_scale(mesh, patch_direct)
    threshold = settings.link_tolerance * expected
    tree = Refiner(hierarchy, light, tree_receivers(hierarchy, light), True, settings.seed, settings.memory_budget)
    root = np.array([hierarchy.root])
    # before any light is solved, each node is taken to show at least the mean radiosity expected
    links = stages.run("linking", (0.05, 0.3), tree.refine, (root, root), np.maximum(radiosity, expected),
                       COARSE * threshold, timer="links")
    solver.link(links)
    radiosity, stats = stages.run("solving", (0.3, 0.45), solver.iterate, radiosity, settings.tolerance,
                                  timer="solve")
    threshold = settings.link_tolerance * max(radiosity_scale(mesh, _unsorted(hierarchy, radiosity)),
                                              np.finfo(float).tiny)
    links = stages.run("linking", (0.45, 0.65), tree.refine, (links.receiver, links.source), radiosity, threshold,
                       timer="links")
    solver.link(links)
    radiosity, stats = stages.run("solving", (0.65, 0.8), solver.iterate, radiosity, settings.tolerance,
                                  timer="solve")
    points = Refiner(hierarchy, light, point_receivers(mesh.node_points, mesh.node_normals),
                     False, settings.seed + 1, settings.memory_budget)
    node_links = stages.run("gathering at vertices", (0.8, 1.0), points.refine,
                            (np.arange(mesh.node_count), np.full(mesh.node_count, hierarchy.root)), radiosity,
                            threshold, timer="gather")
    node_lighting = node_direct + point_light(hierarchy, node_links, radiosity, mesh.node_count, solver.closed)
    patch_radiosity = _unsorted(hierarchy, radiosity)
    stats |= {"links": len(links), "vertex_links": len(node_links), "hierarchy_nodes": hierarchy.node_count,
              "refinement_rounds": tree.rounds + points.rounds}
    extra = 40 * (len(links) + len(node_links)) + hierarchy.node_count * (9 + 2) * 8 * light.channels
    return patch_radiosity, node_lighting, stats, extra
