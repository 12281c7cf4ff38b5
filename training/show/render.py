"""Drawing a pose: the parts of both bodies as hulls, the part contacts as points with their
normals, the body-level summary's normal thicker; PNG through matplotlib, GLB through trimesh.
"""
from __future__ import annotations

import numpy as np

from impactnet.models.compound.hull import hull_of

#: Length of a drawn normal (m): visible next to a 2.6 m container, short beside a 12 m one.
NORMAL_LENGTH_M = 0.3
#: Colours (RGBA 0-1) of body A, body B, the touching parts, the contacts, the summary.
COLOURS = {"a": (0.35, 0.45, 0.75, 0.25), "b": (0.85, 0.55, 0.25, 0.25),
           "touching": (0.85, 0.15, 0.15, 0.6), "contact": (0.1, 0.1, 0.1, 1.0),
           "summary": (0.0, 0.6, 0.2, 1.0)}


def world_faces(part, position, rotation) -> list[np.ndarray]:
    """The part's hull faces as world polygons, each (k, 3) metres."""
    hull = hull_of(part)
    vertices = hull.vertices @ rotation.T + position
    return [vertices[hull.face_loops[f, :hull.face_counts[f]]] for f in range(hull.n_faces)]


def _view_box(answer, bodies):
    """Centre (3,) and half-width of the region worth looking at: the contacts, or all."""
    points = answer.parts.contacts.point
    if not len(points):
        points = np.concatenate([np.concatenate(world_faces(p, pos, rot)) for parts, pos, rot,
                                 _ in bodies for p in parts])
    lo, hi = points.min(axis=0), points.max(axis=0)
    return 0.5 * (lo + hi), max(0.5 * float((hi - lo).max()), 0.4)


def write_png(path, answer, bodies, title: str) -> None:
    """The pose seen obliquely, zoomed onto the contacts. ``bodies``: (parts, position (3,),
    rotation (3, 3), touching part indices) of A and of B."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = plt.figure(figsize=(8, 6), dpi=120)
    ax = fig.add_subplot(projection="3d")
    centre, half = _view_box(answer, bodies)
    for (parts, position, rotation, touching), side in zip(bodies, "ab"):
        for k, part in enumerate(parts):
            faces = world_faces(part, position, rotation)
            if min(np.abs(np.concatenate(faces) - centre).max(axis=1)) > 3 * half:
                continue  # far from the contacts: off the picture
            colour = COLOURS["touching"] if k in touching else COLOURS[side]
            ax.add_collection3d(Poly3DCollection(faces, facecolors=colour,
                                                 edgecolors=(0, 0, 0, 0.15), linewidths=0.3))
    c = answer.parts.contacts
    ax.scatter(*c.point.T, color=COLOURS["contact"], s=8)
    for point, normal in zip(c.point, c.normal):
        ax.plot(*np.stack([point, point + NORMAL_LENGTH_M * normal]).T,
                color=COLOURS["contact"], linewidth=0.8)
    s = answer.summary
    if s.colliding[0]:
        ax.plot(*np.stack([s.point[0], s.point[0] + 2 * NORMAL_LENGTH_M * s.normal[0]]).T,
                color=COLOURS["summary"], linewidth=3)
    ax.set(xlim=(centre[0] - half, centre[0] + half), ylim=(centre[1] - half, centre[1] + half),
           zlim=(centre[2] - half, centre[2] + half), xlabel="x (m)", ylabel="y (m)",
           zlabel="z (m)", title=title)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def write_glb(path, answer, bodies) -> int:
    """The pose as a glTF binary: one mesh per part, a small sphere per contact and a thin
    cylinder per normal; returns the number of meshes."""
    import trimesh

    scene = trimesh.Scene()
    for (parts, position, rotation, touching), side in zip(bodies, "ab"):
        for k, part in enumerate(parts):
            hull = hull_of(part)
            mesh = trimesh.Trimesh(hull.vertices @ rotation.T + position, hull.triangles)
            colour = COLOURS["touching"] if k in touching else COLOURS[side]
            mesh.visual.face_colors = (np.array(colour) * 255).astype(np.uint8)
            scene.add_geometry(mesh, geom_name=f"{side}/{part.name}")
    c = answer.parts.contacts
    for k, (point, normal) in enumerate(zip(c.point, c.normal)):
        marker = trimesh.creation.icosphere(radius=0.01, subdivisions=1)
        marker.apply_translation(point)
        scene.add_geometry(marker, geom_name=f"contact_{k}")
        arrow = trimesh.creation.cylinder(radius=0.003, segment=[point,
                                                                 point + NORMAL_LENGTH_M * normal])
        scene.add_geometry(arrow, geom_name=f"normal_{k}")
    scene.export(path, file_type="glb")
    return len(scene.geometry)
