"""Obstacle merging (thesis Appendix C) and union of overlapping target parts, with manifold3d.

Merging an obstacle into the target makes its surface part of what is imaged, so a wall
hidden behind a shed stuck to it is replaced by the shed's outside, which can be covered.
Booleans need closed meshes; where one is not, the parts are kept side by side instead
(surface buried inside another part is left out by the sampler either way).
"""

from __future__ import annotations

import trimesh

from coverplan.geometry.surface_cover import mesh_distance
from coverplan.world.scene import MeshPart, Scene


def _union(meshes: list[trimesh.Trimesh]) -> trimesh.Trimesh | None:
    if len(meshes) == 1:
        return meshes[0]
    if not all(m.is_watertight for m in meshes):
        return None
    try:
        out = trimesh.boolean.union(meshes, engine="manifold")
    except Exception:  # manifold reports non-manifold input as an empty result or an error
        return None
    return out if out is not None and len(out.faces) else None


def merge_into_target(scene: Scene, within: float) -> Scene:
    """Scene in which obstacles closer than ``within`` to the target, and target parts that
    overlap, are one target mesh (or side-by-side target parts where no boolean is possible).
    Its ``source`` records the merge, so that a route's scene is loaded again the same way.

    Parameters
    ----------
    scene : Scene
        The scene.
    within : float
        Metres.

    Returns
    -------
    Scene
        A new scene.
    """
    merged = _merged(scene, within)
    if scene.source is not None:
        merged = merged if merged is not scene else _rebuilt(scene, list(scene.parts), list(scene.notes))
        merged.source = dict(scene.source, options=dict(scene.source["options"], merge_obstacles_within=float(within)))
    return merged


def _merged(scene: Scene, within: float) -> Scene:
    targets = [p for p in scene.parts if p.role == "target"]
    obstacles = [p for p in scene.parts if p.role == "obstacle"]
    joining = [o for o in obstacles if min(mesh_distance(o.mesh, t.mesh) for t in targets) <= within]
    keep = [o for o in obstacles if o not in joining]
    if not joining and len(targets) == 1:
        return scene
    notes = list(scene.notes)
    group = targets + joining
    merged = _union([p.mesh for p in group])
    names = ", ".join(p.name for p in group)
    if merged is not None:
        parts = [MeshPart(" + ".join(p.name for p in group) if len(group) > 1 else group[0].name, "target", merged)]
        if len(group) > 1:
            notes.append(f"united {names} into one target (manifold union)")
    else:
        parts = [MeshPart(p.name, "target", p.mesh, p.source) for p in group]
        if joining:
            notes.append(f"merged {', '.join(p.name for p in joining)} into the target as separate parts "
                         "(not closed solids, so no boolean union)")
    if joining:
        notes.append(f"{len(joining)} obstacle(s) within {within:g} m of the target now belong to it")
    return _rebuilt(scene, parts + keep, notes)


def unite_overlapping_targets(scene: Scene) -> Scene:
    """Unite target parts that touch or overlap (e.g. building parts), when they are closed.

    Parameters
    ----------
    scene : Scene
        The scene.

    Returns
    -------
    Scene
        ``scene`` itself when nothing overlaps, else a new scene.
    """
    targets = [p for p in scene.parts if p.role == "target"]
    if len(targets) < 2:
        return scene
    touching = any(mesh_distance(a.mesh, b.mesh) == 0.0 for i, a in enumerate(targets) for b in targets[i + 1:])
    if not touching:
        return scene
    merged = _union([p.mesh for p in targets])
    if merged is None:
        return scene
    notes = list(scene.notes) + [f"united {len(targets)} overlapping target parts into one solid (manifold union)"]
    part = MeshPart(" + ".join(p.name for p in targets), "target", merged)
    return _rebuilt(scene, [part] + [p for p in scene.parts if p.role == "obstacle"], notes)


def _rebuilt(scene: Scene, parts, notes) -> Scene:
    """The same scene (frame, ground, georeference) with other parts."""
    return Scene(parts, ground_z=scene.ground_z, crs=scene.crs, origin=scene.origin.copy(), notes=notes,
                 vertical_crs=scene.vertical_crs, geodetic_origin=scene.geodetic_origin,
                 crs_unit_m=scene.crs_unit_m, terrain=scene.terrain, source=scene.source)


__all__ = ["merge_into_target", "unite_overlapping_targets", "mesh_distance"]
