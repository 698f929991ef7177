"""Scenes of many meshes: :class:`Instances` and its answers, :class:`InstanceHits`.

Each mesh is a :class:`kdray.Scene` (its kd-tree built once, shared, never copied per
placement); the meshes are placed by affine transforms under a small tree over the placements'
world boxes (the Rust ``kdray_core::instance`` top level). Moving placements, adding a mesh or
removing one rebuilds that top level alone (``O(n log n)`` in the placements: about 6 ms for
10,000); no mesh's tree is rebuilt.
"""

from __future__ import annotations

import math
import operator
from typing import Any, Dict, Iterable, List, NamedTuple, Optional, Tuple

import numpy as np

from . import Scene, _batch, _build_options, _flag, _kdray, _threads

__all__ = ["Instances", "InstanceHits"]

_F32_MAX = float(np.finfo(np.float32).max)
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])
_IDENTITY = np.eye(3, 4, dtype=np.float32)


class InstanceHits(NamedTuple):
    """The closest hit of each ray (:meth:`Instances.intersect`); arrays of the batch's shape.

    As :class:`kdray.Hits`, and: ``geometry_id`` (int64), the mesh hit (the id
    :meth:`Instances.add_mesh` returned, or its index in the list the scene was made from), and
    ``instance_id`` (int64), which of that mesh's placements (its index in the mesh's
    transforms); both ``-1`` for a miss. ``prim`` is the triangle's index in its own mesh, ``t``
    the distance along the world ray (in units of the direction given), ``u``, ``v`` the
    barycentrics on the mesh's triangle, ``points`` world points and ``normals`` unit world
    normals (mirrored with the mesh under a transform of negative determinant).
    """

    t: np.ndarray
    prim: np.ndarray
    u: np.ndarray
    v: np.ndarray
    geometry_id: np.ndarray
    instance_id: np.ndarray
    points: Optional[np.ndarray] = None
    normals: Optional[np.ndarray] = None


def _placements(x: Any, geometry_id: int) -> np.ndarray:
    """A mesh's transforms as ``(k, 3, 4)`` float32 (object → world, row-major): ``None`` is
    the identity once; ``(4, 4)`` or ``(3, 4)`` one placement, ``(k, 4, 4)`` or ``(k, 3, 4)``
    ``k`` of them (``k`` may be 0)."""
    if x is None:
        return np.eye(3, 4, dtype=np.float32)[None]
    a = np.asarray(x)
    if a.dtype.kind not in "fiu":
        raise TypeError(
            f"transforms of geometry {geometry_id} must hold numbers, not {a.dtype}"
        )
    if a.ndim == 2:
        a = a[None]
    if a.ndim != 3 or a.shape[1:] not in ((4, 4), (3, 4)):
        raise ValueError(
            f"transforms of geometry {geometry_id} must have shape (4, 4), (3, 4), (k, 4, 4) "
            f"or (k, 3, 4), not {np.shape(x)}"
        )
    a = a.astype(np.float64)
    # Checked for every placement at once; the first bad one named.
    problems = [
        (~np.isfinite(a).all(axis=(1, 2)), lambda m: f"the transform is not finite:\n{m}"),
        (
            (a[:, 3] != _LAST_ROW).any(axis=1) if a.shape[1] == 4 else np.zeros(len(a), bool),
            lambda m: f"the last row is {m[3].tolist()}, not [0, 0, 0, 1]: a projective "
            "transform, not an affine one",
        ),
        (
            (np.abs(a[:, :3]) > _F32_MAX).any(axis=(1, 2)),
            lambda m: "the transform is past float32's range (about ±3.4e38)",
        ),
    ]
    for bad, say in problems:
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(f"geometry {geometry_id}, instance {i}: {say(a[i])}")
    return np.ascontiguousarray(a[:, :3, :].astype(np.float32))


def _mesh(mesh: Any, opts: Dict[str, Any]) -> Scene:
    """A mesh as a :class:`Scene`: a scene as it is (shared), ``(vertices, faces)`` or an object
    with ``vertices`` and ``faces`` (a trimesh) built with ``opts``."""
    if isinstance(mesh, Scene):
        return mesh
    if isinstance(mesh, tuple) and len(mesh) == 2:
        return Scene(mesh[0], mesh[1], **opts)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return Scene(np.asarray(mesh.vertices), np.asarray(mesh.faces), **opts)
    raise TypeError(
        "a mesh must be a kdray.Scene, a (vertices, faces) tuple or have .vertices and .faces, "
        f"not {type(mesh).__name__}"
    )


class Instances:
    """A scene of many meshes, each placed by one or more affine transforms.

    ``Instances(meshes=(), transforms=None, *, watertight=False, threads=None, layout=...,
    leaves=..., quality=...)``

    - ``meshes``: a sequence of meshes, each a :class:`kdray.Scene` (shared, not copied), a
      ``(vertices, faces)`` tuple or an object with ``vertices`` and ``faces`` (a
      ``trimesh.Trimesh``), built as :class:`kdray.Scene` builds them with the build options
      and ``threads``. Mesh ``k`` gets geometry id ``k``; :meth:`add_mesh` adds more.
    - ``transforms``: ``None`` (each mesh placed once, as it is), or one entry a mesh: ``None``
      (once, as it is), a ``(4, 4)`` or ``(3, 4)`` object → world matrix (one placement), or a
      stack ``(k, 4, 4)`` / ``(k, 3, 4)`` (``k`` placements, instance ids ``0 .. k-1``; ``k``
      may be 0). Stored in float32. A transform that is not finite, singular (or nearly:
      rows almost dependent), projective (a 4×4 whose last row is not ``0 0 0 1``), or that
      carries its mesh past float32's range raises ``ValueError`` naming the geometry and the
      instance; mirrors, shears and scales huge or tiny are fine.
    - ``watertight``: the walks' triangle test, as :class:`kdray.Scene`'s (the meshes' own
      ``watertight`` is not used); a mesh's ``origin``, if it has one, is folded into its
      transforms.
    - ``merge``: where every mesh is placed once, by the identity (and has no ``origin``), trace
      one tree over all their triangles instead of the two-level walk: the same answers, bit
      for bit, 2–3× faster on 100 meshes with ``quality='high'`` trees (1–2× with the default;
      the package README, "Scenes of many meshes"), for a build over every triangle (their
      stored float32 vertices, with the build options) on the first query after each change:
      adding, removing or moving a mesh then rebuilds that one tree. Otherwise (other placements) the two-level walk answers;
      ``info['merged']`` says which.

    Where every transform is the identity or a translation whose sums are exact in float32,
    the answers are bit for bit those of one :class:`kdray.Scene` over all the meshes'
    triangles (``prim`` then counts within each mesh).

    >>> import numpy as np, kdray
    >>> tri = ([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    >>> up = np.eye(4); up[2, 3] = 5.0                       # moved 5 along z
    >>> scene = kdray.Instances([tri], [np.stack([np.eye(4), up])])
    >>> hit = scene.intersect([[0.2, 0.2, 9.0], [0.2, 0.2, 1.0]], [0, 0, -1])
    >>> hit.t.tolist(), hit.geometry_id.tolist(), hit.instance_id.tolist()
    ([4.0, 1.0], [0, 0], [1, 0])
    """

    def __init__(
        self,
        meshes: Iterable[Any] = (),
        transforms: Optional[Iterable[Any]] = None,
        *,
        watertight: bool = False,
        merge: bool = False,
        threads: Optional[int] = None,
        **build_options: str,
    ) -> None:
        self.watertight = _flag(watertight, "watertight")
        self.merge = _flag(merge, "merge")
        _build_options(build_options)  # refused here, whether or not a mesh is built
        self._opts: Dict[str, Any] = dict(build_options, threads=_threads(threads))
        self._merged: Any = None
        self._meshes: Dict[int, Scene] = {}
        self._transforms: Dict[int, np.ndarray] = {}
        self._next = 0
        self._top: Any = None
        meshes = list(meshes)
        if transforms is None:
            transforms = [None] * len(meshes)
        else:
            transforms = list(transforms)
            if len(transforms) != len(meshes):
                raise ValueError(
                    f"{len(transforms)} entries of transforms for {len(meshes)} meshes: one a "
                    "mesh (None places a mesh once, as it is)"
                )
        for k, (m, x) in enumerate(zip(meshes, transforms)):
            self._meshes[k] = _mesh(m, self._opts)
            self._transforms[k] = _placements(x, k)
        self._next = len(meshes)
        self._top = self._build(self._meshes, self._transforms)

    # -- the top level --------------------------------------------------------------------------

    @staticmethod
    def _arrays(meshes: Dict[int, Scene], transforms: Dict[int, np.ndarray]) -> Any:
        """``(trees, bottom, transforms (n, 12), geometry, instance)`` of every placement, in
        the order of the geometry ids; ``None`` where nothing is placed."""
        ids = sorted(g for g in meshes if len(transforms[g]))
        if not ids:
            return None
        trees, bottom, mats, geometry, instance = [], [], [], [], []
        for b, g in enumerate(ids):
            scene, m = meshes[g], transforms[g]
            if scene.origin is not None:  # local + origin: the translation gains A·origin
                m = m.astype(np.float64)
                m[:, :, 3] += m[:, :, :3] @ scene.origin
                if not np.isfinite(m).all() or (np.abs(m) > _F32_MAX).any():
                    raise ValueError(f"geometry {g}: the transform with the mesh's origin "
                                     "is past float32's range")
                m = m.astype(np.float32)
            trees.append(scene._tree)
            bottom.append(np.full(len(m), b, dtype=np.uint32))
            mats.append(m.reshape(-1, 12))
            geometry.append(np.full(len(m), g, dtype=np.int64))
            instance.append(np.arange(len(m), dtype=np.int64))
        return (trees, np.concatenate(bottom), np.ascontiguousarray(np.concatenate(mats)),
                np.concatenate(geometry), np.concatenate(instance))

    @staticmethod
    def _build(meshes: Dict[int, Scene], transforms: Dict[int, np.ndarray]) -> Any:
        """A new top level over ``meshes`` placed by ``transforms`` (``None``: no placement)."""
        arrays = Instances._arrays(meshes, transforms)
        return None if arrays is None else _kdray.Top.build(*arrays)

    def _mergeable(self, meshes: Dict[int, Scene], transforms: Dict[int, np.ndarray]) -> bool:
        """Whether ``merge`` applies: every mesh placed once, by the identity, no origin."""
        return self.merge and bool(meshes) and all(
            len(m) == 1 and np.array_equal(m[0], _IDENTITY) and meshes[g].origin is None
            for g, m in transforms.items()
        )

    def _one_tree(self) -> Any:
        """``(scene, first triangles, geometry ids)`` of the merged tree where ``merge``
        applies (built on first use after a change), else ``None``. Cached with the dicts of
        meshes and transforms it was made for: every change replaces them (never alters
        them), so a tree built while another thread changed the scene is never taken for the
        new one."""
        meshes, transforms = self._meshes, self._transforms
        cached = self._merged
        if cached is not None and cached[0] is meshes and cached[1] is transforms:
            return cached[2]
        merged = None
        if self._mergeable(meshes, transforms):
            ids = sorted(meshes)
            opts = _build_options({k: v for k, v in self._opts.items() if k != "threads"})
            tree = _kdray.merge(
                [meshes[g]._tree for g in ids],
                opts["layout"], opts["leaves"], opts["quality"], self._opts["threads"],
            )
            counts = [meshes[g].info["triangles"] for g in ids]
            merged = (
                Scene._wrap(tree, self.watertight),
                np.cumsum([0] + counts),
                np.array(ids, dtype=np.int64),
            )
        self._merged = (meshes, transforms, merged)
        return merged

    @staticmethod
    def _ids(merged: Any, prim: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A merged tree's triangles as ``(geometry_id, prim, instance_id)``."""
        _, first, ids = merged
        flat = prim.reshape(-1)  # a fresh array's view: rewritten in place to the meshes' ids
        g, i = _kdray.merged_ids(flat, first, ids)
        return g.reshape(prim.shape), prim, i.reshape(prim.shape)

    def _geometry(self, geometry_id: Any) -> int:
        try:
            g = operator.index(geometry_id)
        except TypeError:
            raise TypeError(
                f"geometry_id must be an int, not {type(geometry_id).__name__}"
            ) from None
        if g not in self._meshes:
            raise KeyError(f"no geometry {g} (the ids: {sorted(self._meshes)})")
        return g

    def add_mesh(self, mesh: Any, transforms: Any = None) -> int:
        """Adds ``mesh`` (as an entry of ``meshes`` in the constructor) placed by
        ``transforms`` (as one entry of ``transforms``) and returns its geometry id (ids are
        never reused). Builds the new mesh's tree, if it is not a :class:`Scene`, and the top
        level; no other mesh's tree."""
        g = self._next
        scene, m = _mesh(mesh, self._opts), _placements(transforms, g)
        meshes, trans = dict(self._meshes), dict(self._transforms)
        meshes[g], trans[g] = scene, m
        self._top = self._build(meshes, trans)
        self._meshes, self._transforms, self._next = meshes, trans, g + 1
        return g

    def remove_mesh(self, geometry_id: int) -> None:
        """Removes a mesh and its placements (its id is not reused); rebuilds the top level."""
        g = self._geometry(geometry_id)
        meshes, trans = dict(self._meshes), dict(self._transforms)
        del meshes[g], trans[g]
        self._top = self._build(meshes, trans)
        self._meshes, self._transforms = meshes, trans

    def set_transforms(self, geometry_id: int, transforms: Any) -> None:
        """Places mesh ``geometry_id`` anew (``transforms`` as in the constructor; the number of
        placements may change): rebuilds the top level alone, or, as many placements moved,
        refits it (the same tree with its boxes redrawn; built anew once refits have loosened
        it by half). On an error nothing changes."""
        g = self._geometry(geometry_id)
        trans = dict(self._transforms)
        trans[g] = _placements(transforms, g)
        top = self._top
        if top is not None and len(trans[g]) == len(self._transforms[g]):
            self._top = top.moved(self._arrays(self._meshes, trans)[2])
        else:
            self._top = self._build(self._meshes, trans)
        self._transforms = trans

    def transforms(self, geometry_id: int) -> np.ndarray:
        """Mesh ``geometry_id``'s placements as ``(k, 4, 4)`` float64 (the float32 values
        stored)."""
        m = self._transforms[self._geometry(geometry_id)]
        out = np.zeros((len(m), 4, 4))
        out[:, :3, :] = m
        out[:, 3, 3] = 1.0
        return out

    def mesh(self, geometry_id: int) -> Scene:
        """Mesh ``geometry_id``'s :class:`Scene`."""
        return self._meshes[self._geometry(geometry_id)]

    @property
    def geometry_ids(self) -> List[int]:
        """The meshes' ids, in increasing order."""
        return sorted(self._meshes)

    def __len__(self) -> int:
        """The number of placements (instances) of every mesh."""
        return sum(len(m) for m in self._transforms.values())

    @property
    def info(self) -> dict:
        """``meshes``, ``instances``, ``triangles`` (of every placement), the top level's
        ``nodes``, ``depth`` and ``bytes``, the world ``bounds`` (``None`` when nothing is
        placed), and ``merged``: whether rays go through one merged tree (``merge``)."""
        top = {} if self._top is None else self._top.info()
        return {
            "meshes": len(self._meshes),
            "instances": len(self),
            "triangles": sum(
                self._meshes[g].info["triangles"] * len(m) for g, m in self._transforms.items()
            ),
            "nodes": top.get("nodes", 0),
            "depth": top.get("depth", 0),
            "bytes": top.get("bytes", 0),
            "bounds": top.get("bounds"),
            "merged": self._mergeable(self._meshes, self._transforms),
        }

    def __repr__(self) -> str:
        return (
            f"kdray.Instances({len(self._meshes)} meshes, {len(self)} instances, "
            f"watertight={self.watertight}, merge={self.merge})"
        )

    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        """Pickles the meshes (each a :class:`Scene`: its tree's words, not rebuilt on the
        other side), their transforms and ids; unpickling rebuilds the top level alone."""
        ids = sorted(self._meshes)
        return _restore, (
            ids,
            [self._meshes[g] for g in ids],
            [self._transforms[g] for g in ids],
            self._next,
            self.watertight,
            self.merge,
        )

    # -- rays -----------------------------------------------------------------------------------

    def intersect(
        self,
        origins: Any,
        directions: Any,
        tmin: Any = 0.0,
        tmax: Any = math.inf,
        *,
        points: bool = False,
        normals: bool = False,
        threads: Optional[int] = None,
    ) -> InstanceHits:
        """The closest hit of each ray ``origin + t·direction``, ``tmin < t < tmax``, over every
        placement of every mesh: :class:`InstanceHits` of the batch's shape (arguments as
        :meth:`kdray.Scene.intersect`)."""
        merged = self._one_tree()
        if merged is not None:
            h = merged[0].intersect(
                origins, directions, tmin, tmax, points=points, normals=normals, threads=threads
            )
            g, prim, i = self._ids(merged, h.prim)
            return InstanceHits(h.t, prim, h.u, h.v, g, i, h.points, h.normals)
        top = self._top  # read once: another thread may place meshes meanwhile
        b = _batch(origins, directions, tmin, tmax)
        points, normals = _flag(points, "points"), _flag(normals, "normals")
        threads = _threads(threads)
        shape = b.shape
        if top is None:
            _kdray.check_rays(b)
            nan3 = np.full(shape + (3,), np.nan, dtype=np.float32)
            return InstanceHits(
                np.full(shape, np.inf, dtype=np.float32),
                np.full(shape, -1, dtype=np.int64),
                np.zeros(shape, dtype=np.float32),
                np.zeros(shape, dtype=np.float32),
                np.full(shape, -1, dtype=np.int64),
                np.full(shape, -1, dtype=np.int64),
                nan3 if points else None,
                nan3.copy() if normals else None,
            )
        t, prim, u, v, g, i, p, n = top.intersect(b, self.watertight, points, normals, threads)
        return InstanceHits(
            t.reshape(shape),
            prim.reshape(shape),
            u.reshape(shape),
            v.reshape(shape),
            g.reshape(shape),
            i.reshape(shape),
            None if p is None else p.reshape(shape + (3,)),
            None if n is None else n.reshape(shape + (3,)),
        )

    def raycast(
        self, origin: Any, direction: Any, tmin: float = 0.0, tmax: float = math.inf
    ) -> Tuple[float, int, float, float, int, int]:
        """One ray's closest hit as Python numbers, ``(t, prim, u, v, geometry_id,
        instance_id)`` (``(inf, -1, 0.0, 0.0, -1, -1)`` for a miss), without arrays.

        >>> import kdray
        >>> kdray.Instances([([[0, 0, 0], [1, 0, 0], [0, 1, 0]], None)]).raycast(
        ...     (0.25, 0.5, 1), (0, 0, -1))
        (1.0, 0, 0.25, 0.5, 0, 0)
        """
        top = self._top
        if top is None:
            # One ray checked as a batch, for the same errors.
            self.intersect(origin, direction, tmin, tmax)
            return (math.inf, -1, 0.0, 0.0, -1, -1)
        for name, x in (("origin", origin), ("direction", direction)):
            if np.shape(x) != (3,):
                raise TypeError(f"{name} must be 3 numbers, not {x!r}")
        merged = self._one_tree()
        if merged is not None:
            t, prim, u, v = merged[0].raycast(origin, direction, tmin, tmax)
            g, prim, i = (int(x) for x in self._ids(merged, np.array(prim)))
            return (t, prim, u, v, g, i)
        try:
            return top.raycast(origin, direction, tmin, tmax, self.watertight)
        except (TypeError, ValueError):
            # The batch's checks and words for the one ray (past float32, NaN, zero, ...).
            self.intersect(origin, direction, tmin, tmax)
            raise

    def occluded(
        self,
        origins: Any,
        directions: Any,
        tmin: Any = 0.0,
        tmax: Any = math.inf,
        *,
        threads: Optional[int] = None,
    ) -> np.ndarray:
        """Whether any placed triangle lies along each ray in ``(tmin, tmax)``: a bool array
        (arguments as :meth:`intersect`)."""
        merged = self._one_tree()
        if merged is not None:
            return merged[0].occluded(origins, directions, tmin, tmax, threads=threads)
        top = self._top
        b = _batch(origins, directions, tmin, tmax)
        threads = _threads(threads)
        if top is None:
            _kdray.check_rays(b)
            return np.zeros(b.shape, dtype=bool)
        return top.occluded(b, self.watertight, threads).reshape(b.shape)


def _restore(
    ids: List[int],
    meshes: List[Scene],
    transforms: List[np.ndarray],
    next_id: int,
    watertight: bool,
    merge: bool = False,
) -> Instances:
    """The scene :meth:`Instances.__reduce__` pickled (the meshes validated as they unpickled)."""
    if not (
        isinstance(ids, list) and isinstance(meshes, list) and isinstance(transforms, list)
        and len(ids) == len(meshes) == len(transforms)
        and all(isinstance(m, Scene) for m in meshes)
        and all(type(g) is int and 0 <= g < next_id for g in ids)
    ):
        raise ValueError("a pickled kdray.Instances: its meshes, ids and transforms do not match")
    out = Instances.__new__(Instances)
    out.watertight = _flag(watertight, "watertight")
    out.merge = _flag(merge, "merge")
    out._merged = None
    out._opts = {"threads": None}
    out._meshes = dict(zip(ids, meshes))
    out._transforms = {g: _placements(m, g) for g, m in zip(ids, transforms)}
    out._next = next_id
    out._top = Instances._build(out._meshes, out._transforms)
    return out
