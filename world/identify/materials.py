"""Material and mass, both ways.

* ``prior_mass``: the mass a body of a material and shape would have (density
  x volume), the semantic prior of identification's stage 3 for bodies whose
  mass no collision shows.
* ``revise_materials``: a perceived body's material belief revised by the mass
  ratios its collisions identified. Collisions identify only mass ratios
  (docs/identification.md); the densities of the materials differ
  (FitConfig.density_prior: metal 2700, rubber 1100 kg/m^3), so the fitted
  density ratio of two colliding bodies says whether they are of one material
  and, if not, which is the metal one. Appearance alone cannot always tell
  (a matte paint on metal, a glossy rubber, a highlight that never faces the
  camera); the dynamics cue does not depend on the renderer.

The revision is Bayesian over each group of bodies linked by informative
collisions: prior = perception's belief per body (independent), likelihood per
link = a robust normal density of the fitted log density ratio about the one
the two materials would give. Every joint assignment of the group's materials
is enumerated (two materials, at most MAX_GROUP_BODIES bodies). A world whose
materials all weigh the same breaks the assumption: then the cue pulls the
materials of colliding bodies together (FitConfig.materials_from_masses=False
turns it off).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Mapping, Sequence

from world.identify.graph import connected_components
from world.types import AttributeBelief, Body, Shape, World

# Spread (natural-log units) of a fitted log density ratio about the one its
# two materials give: the fit's error on the mass ratio and the spread of real
# densities within a material. Measured on the worlds from video of the
# development set (seed 7373): two bodies of one material, median |log ratio|
# 0.27, which is 0.4 for a normal spread (median of |N(0, s)| = 0.674 s).
RATIO_SIGMA = 0.4
# Share of fitted ratios that say nothing about the materials (a wrong fit, a
# wrong shape and so volume): spread uniformly over RATIO_SPAN log units
# (the mass-ratio bounds 1/20 to 20 of the fit).
RATIO_OUTLIER_SHARE = 0.2
RATIO_SPAN = 2.0 * math.log(20.0)
# A link counts only when the fit explains both bodies' tracks to within this RMS (m, a
# quarter of an object's size): a mass ratio from a fit that misses the tracks is no
# evidence. Chosen on five development sets (docs/benchmarks.md, "Ninth round ...: material from the
# mass ratios of collisions").
MAX_LINK_RMSE = 0.05
MAX_GROUP_BODIES = 12  # 2^12 assignments; a larger group keeps perception's beliefs
REPORT_CHANGE = 0.1  # a revision that moves P(material) by at least this is flagged in the fit report
REVISION_FLAG = "material from mass ratios"  # how that flag begins


def shape_volume(shape: Shape) -> float:
    """m^3: the primitive's volume, or the mesh's when the shape names one."""
    if shape.mesh_path:
        import trimesh  # only for worlds that carry meshes

        return float(trimesh.load(shape.mesh_path, force="mesh").volume)
    if shape.kind == "sphere":
        return 4.0 / 3.0 * math.pi * shape.radius**3
    if shape.kind == "cube":
        return (2.0 * shape.half_extent) ** 3
    return math.pi * shape.radius**2 * 2.0 * shape.half_height


def material_density(material: str | None, density: Mapping[str, float]) -> float:
    """kg/m^3 of a named material; the geometric mean of the known ones when it is unknown."""
    if material in density:
        return float(density[material])
    return float(math.exp(sum(math.log(v) for v in density.values()) / len(density)))


def prior_mass(shape: Shape, material: str | None, density: Mapping[str, float]) -> float:
    """kg: density of the material x volume of the shape."""
    return shape_volume(shape) * material_density(material, density)


@dataclass(frozen=True)
class MaterialRevision:
    """One body's material belief before and after its collisions' mass ratios (value -> p)."""

    body: int
    before: Mapping[str, float]
    after: Mapping[str, float]
    partners: tuple[int, ...]

    def message(self) -> str:
        def show(belief: Mapping[str, float]) -> str:
            return ", ".join(f"{m} {p:.2f}" for m, p in sorted(belief.items()))

        return (f"{REVISION_FLAG} with bodies {list(self.partners)}: "
                f"{show(self.before)} -> {show(self.after)}")


def _robust_normal(x: float) -> float:
    core = math.exp(-0.5 * (x / RATIO_SIGMA) ** 2) / (RATIO_SIGMA * math.sqrt(2.0 * math.pi))
    return (1.0 - RATIO_OUTLIER_SHARE) * core + RATIO_OUTLIER_SHARE / RATIO_SPAN


def revise_materials(world: World, links: Sequence[tuple[int, int]], density: Mapping[str, float],
                     mass_groups: Sequence[Sequence[int]] = (),
                     rmse: Mapping[int, float] | None = None) -> tuple[World, tuple[MaterialRevision, ...]]:
    """The world with each linked body's material belief (and material) revised by its mass ratios.

    links: pairs of body ids whose collision identified their mass ratio.
    Only bodies with a material belief over the materials of ``density`` take
    part. rmse: body id -> the fit's RMSE (m) over its observed samples; when
    given, a link counts only if both bodies are within MAX_LINK_RMSE.
    mass_groups: sets of bodies that share one mass scale (a contact-
    connected component of the fit); when a member's material changes, the
    group's masses are scaled so that their geometric mean follows the
    members' prior masses (ratios unchanged, so the observed replay is too).
    Returns the new world and one MaterialRevision per revised body.
    """
    bodies = {b.id: b for b in world.bodies}
    materials = tuple(density)
    beliefs = {i: _material_belief(body, materials) for i, body in bodies.items()}

    def usable_body(i: int) -> bool:
        fitted = rmse is None or rmse.get(i, math.inf) <= MAX_LINK_RMSE  # NaN (never observed) compares False
        return beliefs.get(i) is not None and fitted

    usable = [(a, b) for a, b in links if a != b and usable_body(a) and usable_body(b)]
    log_density = {i: math.log(bodies[i].mass / shape_volume(bodies[i].shape)) for pair in usable for i in pair}
    revisions: list[MaterialRevision] = []
    for group in connected_components((), usable):
        if len(group) > MAX_GROUP_BODIES:
            continue
        members = set(group)
        edges = sorted({(min(a, b), max(a, b)) for a, b in usable if a in members})
        priors = {i: beliefs[i] for i in group}
        marginal = {i: dict.fromkeys(materials, 0.0) for i in group}
        evidence = 0.0
        for assignment in itertools.product(materials, repeat=len(group)):
            chosen = dict(zip(group, assignment))
            weight = math.prod(priors[i][chosen[i]] for i in group)
            if weight == 0.0:
                continue
            for a, b in edges:
                expected = math.log(density[chosen[a]] / density[chosen[b]])
                weight *= _robust_normal(log_density[a] - log_density[b] - expected)
            evidence += weight
            for i in group:
                marginal[i][chosen[i]] += weight
        if evidence <= 0.0:
            continue
        for i in group:
            after = {m: marginal[i][m] / evidence for m in materials}
            partners = tuple(sorted({b if a == i else a for a, b in edges if i in (a, b)}))
            revisions.append(MaterialRevision(i, priors[i], after, partners))
    if not revisions:
        return world, ()
    revised = {r.body: r for r in revisions}
    new_bodies = {i: _with_material(bodies[i], revised[i].after) if i in revised else bodies[i] for i in bodies}
    for group in mass_groups:
        changed = [i for i in group if i in revised and new_bodies[i].material != bodies[i].material]
        if not changed:
            continue
        members = [i for i in group if i in bodies]
        shift = sum(math.log(material_density(new_bodies[i].material, density) / material_density(bodies[i].material, density))
                    for i in members) / len(members)
        for i in members:
            new_bodies[i] = replace(new_bodies[i], mass=new_bodies[i].mass * math.exp(shift))
    return replace(world, bodies=tuple(new_bodies[b.id] for b in world.bodies)), tuple(revisions)


def _material_belief(body: Body, materials: tuple[str, ...]) -> dict[str, float] | None:
    """The body's belief over ``materials`` (renormalised), or None without a belief that names one of them."""
    if body.attribute_belief is None:
        return None
    values = {m: p for m, p in body.attribute_belief.distribution("material").items() if m in materials}
    total = sum(values.values())
    return {m: values.get(m, 0.0) / total for m in materials} if total > 0 else None


def _with_material(body: Body, after: Mapping[str, float]) -> Body:
    belief: AttributeBelief = body.attribute_belief
    return replace(body, material=max(after, key=after.get), attribute_belief=replace(belief, material=tuple(after.items())))
