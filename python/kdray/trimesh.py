"""A drop-in ray intersector for trimesh: ``mesh.ray = kdray.trimesh.RayMeshIntersector(mesh)``.

It has trimesh's method names, arguments and return shapes (``trimesh.ray.ray_triangle`` and
``ray_pyembree``): ``intersects_first``, ``intersects_any``, ``intersects_id``,
``intersects_location`` and ``contains_points``, answered by a :class:`kdray.Scene` built over
``mesh.vertices`` and ``mesh.faces`` (rebuilt when the mesh changes). Multiple hits are every
exact crossing (:meth:`kdray.Scene.intersect_all`): a ray through a shared edge is reported once,
not once per triangle, and ``contains_points`` is exact where trimesh's ray test is not.

A ``trimesh.Scene`` (meshes placed by its graph's transforms) becomes a :class:`kdray.Instances`
through :func:`instances`, with the names of its geometry and nodes.

trimesh itself is not imported here: the intersector reads the mesh's arrays.

Example::

    >>> import trimesh, kdray.trimesh
    >>> mesh = trimesh.creation.icosphere()
    >>> mesh.ray = kdray.trimesh.RayMeshIntersector(mesh)
    >>> mesh.ray.intersects_first([[0, 0, -5]], [[0, 0, 1]]).shape
    (1,)
    >>> mesh.contains([[0, 0, 0], [0, 0, 2]]).tolist()
    [True, False]
"""

from __future__ import annotations

from typing import Any, List, NamedTuple

import numpy as np

from . import Instances, Scene

__all__ = ["RayMeshIntersector", "SceneInstances", "instances"]


class SceneInstances(NamedTuple):
    """A ``trimesh.Scene`` as :func:`instances` gives it: the :class:`kdray.Instances`, and the
    names its answers' ids stand for: ``geometry_names[geometry_id]`` (a key of
    ``scene.geometry``) and ``node_names[geometry_id][instance_id]`` (a node of
    ``scene.graph``)."""

    instances: Instances
    geometry_names: List[str]
    node_names: List[List[str]]


def instances(scene: Any, *, watertight: bool = False, **build_options: Any) -> SceneInstances:
    """The triangle meshes of a ``trimesh.Scene`` placed as its graph places them: one
    :class:`kdray.Scene` a geometry (built once however many nodes show it) and one placement a
    node (``scene.graph[node]``'s world transform). Geometry without faces (paths, point
    clouds, empty meshes) and geometry no node shows are left out. ``watertight`` and the build
    options as for :class:`kdray.Instances`.

    >>> import numpy as np, trimesh, kdray.trimesh
    >>> scene = trimesh.Scene()
    >>> node = scene.add_geometry(trimesh.creation.box(), geom_name="box", node_name="here")
    >>> moved = np.eye(4); moved[0, 3] = 5.0                  # a second node, 5 along x
    >>> scene.graph.update(frame_to="there", geometry="box", matrix=moved)
    >>> found = kdray.trimesh.instances(scene)
    >>> hit = found.instances.intersect([5.1, 0.2, -9], [0, 0, 1])
    >>> g, i = int(hit.geometry_id), int(hit.instance_id)
    >>> found.geometry_names[g], found.node_names[g][i], float(hit.t)
    ('box', 'there', 8.5)
    """
    nodes_of = scene.graph.geometry_nodes
    meshes, transforms, geometry_names, node_names = [], [], [], []
    for name, geom in scene.geometry.items():
        faces = getattr(geom, "faces", None)
        nodes = list(nodes_of.get(name, ()))
        if faces is None or len(faces) == 0 or not nodes:
            continue
        meshes.append((np.asarray(geom.vertices), np.asarray(faces)))
        transforms.append(np.stack([np.asarray(scene.graph[n][0], dtype=np.float64)
                                    for n in nodes]))
        geometry_names.append(name)
        node_names.append(nodes)
    return SceneInstances(
        Instances(meshes, transforms, watertight=watertight, **build_options),
        geometry_names,
        node_names,
    )


class RayMeshIntersector:
    """Ray queries on a trimesh ``Trimesh`` through a kdray :class:`~kdray.Scene`.

    ``watertight`` and the build options (``layout``, ``leaves``, ``quality``, ``threads``) are
    passed to the scene (:class:`kdray.Scene`). The scene is built around the centre of the
    mesh (``origin='auto'``): trimesh's float64 coordinates far from zero keep their precision
    near the mesh (kdray traces in float32). A ray with a zero direction misses, as in trimesh.
    """

    def __init__(self, mesh: Any, *, watertight: bool = False, **build_options: Any) -> None:
        self.mesh = mesh
        self._options = dict(build_options, watertight=watertight)
        self._options.setdefault("origin", "auto")
        self._scene = None
        self._key = None

    @property
    def scene(self) -> Scene:
        """The :class:`kdray.Scene` over the mesh as it is now (built on first use and again
        after the mesh changed)."""
        key = hash(self.mesh)
        if self._scene is None or key != self._key:
            self._scene = Scene(
                np.asarray(self.mesh.vertices), np.asarray(self.mesh.faces), **self._options
            )
            self._key = key
        return self._scene

    @staticmethod
    def _rays(ray_origins: Any, ray_directions: Any):
        o = np.asarray(ray_origins, dtype=np.float64)
        d = np.asarray(ray_directions, dtype=np.float64)
        if o.ndim != 2 or o.shape[1] != 3:
            raise ValueError(f"ray_origins must have shape (n, 3), not {o.shape}")
        if d.shape != o.shape:
            raise ValueError(
                f"ray_directions has shape {d.shape}, not ray_origins' {o.shape}"
            )
        return o, d

    @staticmethod
    def _nonzero(d: np.ndarray):
        """``d`` with zero rows replaced by a direction the scene accepts, and the mask of the
        rays kept (trimesh answers a miss for a zero direction; the scene refuses it)."""
        keep = (d != 0).any(axis=1)
        if keep.all():
            return d, None
        d = d.copy()
        d[~keep] = (1.0, 0.0, 0.0)
        return d, keep

    def intersects_first(self, ray_origins: Any, ray_directions: Any, **kwargs: Any) -> np.ndarray:
        """The index of the first triangle each ray hits, -1 for none: ``(n,)`` int64."""
        o, d = self._rays(ray_origins, ray_directions)
        d, keep = self._nonzero(d)
        prim = self.scene.intersect(o, d).prim
        if keep is not None:
            prim[~keep] = -1
        return prim

    def intersects_any(self, ray_origins: Any, ray_directions: Any, **kwargs: Any) -> np.ndarray:
        """Whether each ray hits the mesh: ``(n,)`` bool."""
        o, d = self._rays(ray_origins, ray_directions)
        d, keep = self._nonzero(d)
        hit = self.scene.occluded(o, d)
        return hit if keep is None else hit & keep

    def intersects_id(
        self,
        ray_origins: Any,
        ray_directions: Any,
        return_locations: bool = False,
        multiple_hits: bool = True,
        **kwargs: Any,
    ):
        """The triangles hit and the rays hitting them: ``index_tri (h,)``, ``index_ray (h,)``
        (int64), and with ``return_locations`` the points ``(h, 3)`` (float64). Every crossing
        with ``multiple_hits`` (sorted by ray, then along it), else the first hit of each ray
        that hits."""
        o, d0 = self._rays(ray_origins, ray_directions)
        d, keep = self._nonzero(d0)
        if multiple_hits:
            ray, t, tri = self.scene.intersect_all(o, d)
        else:
            hits = self.scene.intersect(o, d)
            ray = np.flatnonzero(hits.prim >= 0)
            t, tri = hits.t[ray], hits.prim[ray]
        if keep is not None:
            kept = keep[ray]
            ray, t, tri = ray[kept], t[kept], tri[kept]
        if not return_locations:
            return tri, ray
        locations = o[ray] + t.astype(np.float64)[:, None] * d[ray]
        return tri, ray, locations

    def intersects_location(
        self, ray_origins: Any, ray_directions: Any, multiple_hits: bool = True, **kwargs: Any
    ):
        """Where rays hit the mesh: ``locations (h, 3)`` float64, ``index_ray (h,)``,
        ``index_tri (h,)`` (int64)."""
        tri, ray, locations = self.intersects_id(
            ray_origins, ray_directions, return_locations=True, multiple_hits=multiple_hits
        )
        return locations, ray, tri

    def contains_points(self, points: Any) -> np.ndarray:
        """Whether each point lies inside the (closed) mesh: ``(n,)`` bool, exact where the test
        ray passes through edges and vertices (:meth:`kdray.Scene.contains`)."""
        p = np.asarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f"points must have shape (n, 3), not {p.shape}")
        return self.scene.contains(p)
