"""kdray: ray casting against triangle meshes through an SAH kd-tree, for numpy.

A :class:`Scene` is built from an ``(N, 3)`` vertex array and an ``(M, 3)`` face array (or loaded
from a mesh or ``.kdt`` file); its methods take batches of rays as arrays and answer with arrays,
working on every core without the GIL::

    >>> import numpy as np, kdray
    >>> vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32)
    >>> scene = kdray.Scene(vertices, [[0, 1, 2]])
    >>> hits = scene.intersect([[0.25, 0.25, 1.0], [2.0, 2.0, 1.0]], [0.0, 0.0, -1.0])
    >>> hits.t.tolist(), hits.prim.tolist()
    ([1.0, inf], [0, -1])

The tree is built by the same code as ``kdray build`` and the rays are traced by the same walks
as ``kdray trace`` (the Rust crates ``kdray`` and ``kdray-core``); ``count_intersections``,
``intersect_all`` and ``contains`` count crossings exactly on shared edges and vertices, so that
``contains`` is right for points whose rays pass through them.
"""

from __future__ import annotations

import errno
import importlib.metadata as _metadata
import math
import operator
import os
from typing import Any, NamedTuple, Optional, Tuple

import numpy as np

from . import _kdray

__all__ = ["Scene", "Hits", "AllHits", "CONTAINS_DIRECTION", "ISA", "__version__"]

#: The direction in which :meth:`Scene.contains` casts its rays.
CONTAINS_DIRECTION = tuple(float(x) for x in _kdray.CONTAINS_DIRECTION)

#: The instruction set the extension's SIMD was compiled for, as ``kdray --version`` names it
#: (``'avx2+fma'``, ``'avx'``, ``'sse2'``, ...): a build from source compiles for the CPU that
#: builds it (the repository's ``.cargo/config.toml``), a portable wheel for SSE2.
ISA: str = _kdray.ISA

try:
    #: The installed package's version (``pip show kdray``'s).
    __version__: str = _metadata.version("kdray")
except _metadata.PackageNotFoundError:  # imported from a source tree, not installed
    __version__ = "0+unknown"

_BUILD_OPTIONS = {
    "layout": ("wide", "nodes"),
    "leaves": ("groups", "list"),
    "quality": ("fast", "high"),
}
_DEFAULTS = {"layout": "wide", "leaves": "groups", "quality": "fast"}


class Hits(NamedTuple):
    """The closest hit of each ray (:meth:`Scene.intersect`); arrays of the batch's shape.

    ``t`` is ``inf`` for a miss and ``prim`` ``-1``; ``u``, ``v`` are the barycentric
    coordinates of the hit (``p = v0 + u·(v1 − v0) + v·(v2 − v0)``, 0 for a miss). ``points``
    (the hits, ``origin + t·direction``) and ``normals`` (the triangles' unit geometric normals,
    ``(v1 − v0) × (v2 − v0)`` normalized) have a trailing axis of 3, NaN for a miss, and are
    ``None`` unless asked for.
    """

    t: np.ndarray
    prim: np.ndarray
    u: np.ndarray
    v: np.ndarray
    points: Optional[np.ndarray] = None
    normals: Optional[np.ndarray] = None


class AllHits(NamedTuple):
    """Every crossing of every ray (:meth:`Scene.intersect_all`), flattened: ray ``ray[k]``
    (its index in the flattened batch) crosses triangle ``prim[k]`` at ``t[k]``; sorted by ray,
    then by ``t``."""

    ray: np.ndarray
    t: np.ndarray
    prim: np.ndarray


def _threads(threads: Any) -> Optional[int]:
    if threads is None:
        return None
    try:
        n = operator.index(threads)
    except TypeError:
        raise TypeError(
            f"threads must be an int or None, not {type(threads).__name__}"
        ) from None
    if not 1 <= n <= 4096:
        raise ValueError(f"threads={n}: it must be at least 1 (and at most 4096)")
    return n


def _float_array(x: Any, name: str) -> np.ndarray:
    """``x`` as a float32 array: read in place when it is one, converted once otherwise."""
    if type(x) is np.ndarray and x.dtype == np.float32:
        return x
    a = np.asarray(x)
    if a.dtype == np.float32:
        return a
    if a.dtype.kind not in "fiu":
        raise TypeError(f"{name} must hold numbers (float32 or float64), not {a.dtype}")
    with np.errstate(over="ignore", invalid="ignore"):
        return a.astype(np.float32)


def _points(x: Any, name: str) -> Tuple[np.ndarray, Tuple[int, ...]]:
    """An array of 3-vectors: ``(..., 3)``, as ``(k, 3)`` C-contiguous float32 and the leading
    shape."""
    a = _float_array(x, name)
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (..., 3), not {a.shape}")
    return a, a.shape[:-1]


def _rows(a: np.ndarray, lead: Tuple[int, ...], shape: Tuple[int, ...], width: int) -> np.ndarray:
    """``a`` (leading shape ``lead``) for a batch of ``shape``: one row when it has one element
    (shared by every ray, not copied), else all of them, broadcast and made contiguous."""
    if lead == shape and a.flags.c_contiguous:
        return a.reshape((-1, width) if width > 1 else (-1,))
    if math.prod(lead) == 1:
        return np.ascontiguousarray(a.reshape((1, width) if width > 1 else (1,)))
    if lead != shape:
        a = np.broadcast_to(a, shape + ((width,) if width > 1 else ()))
    n = math.prod(shape)
    return np.ascontiguousarray(a.reshape((n, width) if width > 1 else (n,)))


class _Batch(NamedTuple):
    """What the extension's batch calls take (python/src/lib.rs, ``RayArgs``)."""

    origins: np.ndarray
    directions: np.ndarray
    tmin: np.ndarray
    tmax: np.ndarray
    n: int
    shape: Tuple[int, ...]


def _interval(x: Any, name: str) -> np.ndarray:
    if type(x) is float or type(x) is int:
        return np.array((x,), dtype=np.float32).reshape(())
    return _float_array(x, name)


def _batch(origins: Any, directions: Any, tmin: Any, tmax: Any) -> _Batch:
    o, o_lead = _points(origins, "origins")
    d, d_lead = _points(directions, "directions")
    lo = _interval(tmin, "tmin")
    hi = _interval(tmax, "tmax")
    if o_lead == d_lead and lo.ndim == 0 and hi.ndim == 0:
        shape = o_lead  # the common case, without numpy's general rule
    else:
        try:
            shape = np.broadcast_shapes(o_lead, d_lead, lo.shape, hi.shape)
        except ValueError:
            raise ValueError(
                f"origins {o.shape}, directions {d.shape}, tmin {lo.shape} and tmax "
                f"{hi.shape} do not broadcast to one batch of rays"
            ) from None
    return _Batch(
        _rows(o, o_lead, shape, 3),
        _rows(d, d_lead, shape, 3),
        _rows(lo, lo.shape, shape, 1),
        _rows(hi, hi.shape, shape, 1),
        math.prod(shape),
        shape,
    )


def _build_options(options: dict) -> dict:
    out = dict(_DEFAULTS)
    for key, value in options.items():
        if key not in _BUILD_OPTIONS:
            raise TypeError(
                f"unknown build option {key!r} (the options: {', '.join(_BUILD_OPTIONS)})"
            )
        if value not in _BUILD_OPTIONS[key]:
            retired = (
                " ('blocked' was retired in kdray's format 12: 'wide' replaces it)"
                if (key, value) == ("layout", "blocked")
                else ""
            )
            raise ValueError(
                f"{key}={value!r}: it must be one of "
                f"{', '.join(map(repr, _BUILD_OPTIONS[key]))}{retired}"
            )
        out[key] = value
    return out


class Scene:
    """A triangle mesh and its SAH kd-tree, ready to trace rays.

    ``Scene(vertices, faces=None, *, watertight=False, threads=None, layout='wide',
    leaves='groups', quality='fast')``

    - ``vertices``: ``(N, 3)`` floats (float32 is used as given, float64 converted once).
    - ``faces``: ``(M, 3)`` integer vertex indices; ``None``: every 3 vertices are a triangle.
    - ``watertight``: trace :meth:`intersect` and :meth:`occluded` with the watertight triangle
      test and a conservative walk, so that no ray slips between triangles that share an edge
      (slower); :meth:`count_intersections`, :meth:`intersect_all` and :meth:`contains` are
      always exact.
    - ``threads``: the threads the build uses (default: every core).
    - build options: ``layout`` (``'wide'``: also store the tree as eight-wide nodes with tight
      boxes, which single rays walk faster; or ``'nodes'``: the binary nodes only, a smaller
      tree), ``leaves`` (``'groups'``: triangles four to a SIMD group,
      or ``'list'``: index lists) and ``quality`` (``'fast'``: binned planes, 2.5–3× faster to
      build than ``'high'``, the exact sweep, whose tree takes about 8 % fewer instructions a
      ray), as ``kdray build --layout/--leaves/--quality``.

    Triangles are reported by their index in ``faces`` (input order). Degenerate triangles are
    kept in the numbering and never hit. Bad input raises ``ValueError`` (values) or
    ``TypeError`` (types) naming the argument.

    Example::

        >>> import numpy as np, kdray
        >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
        >>> tetra = kdray.Scene(v, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
        >>> tetra.contains([[0.1, 0.1, 0.1], [1.0, 1.0, 1.0]]).tolist()
        [True, False]
    """

    __slots__ = ("_tree", "watertight")

    def __init__(
        self,
        vertices: Any,
        faces: Any = None,
        *,
        watertight: bool = False,
        threads: Optional[int] = None,
        **build_options: str,
    ) -> None:
        opts = _build_options(build_options)
        threads = _threads(threads)
        v = _float_array(vertices, "vertices")
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"vertices must have shape (N, 3), not {v.shape}")
        f = None
        if faces is not None:
            f = np.asarray(faces)
            if f.dtype.kind not in "iu":
                raise TypeError(f"faces must hold integers, not {f.dtype}")
            if f.ndim != 2 or f.shape[1] != 3:
                raise ValueError(f"faces must have shape (M, 3), not {f.shape}")
            if f.dtype.kind == "u" and f.size and f.max() > np.iinfo(np.int64).max:
                raise ValueError(f"faces holds {f.max()}, past any vertex index")
            f = np.ascontiguousarray(f, dtype=np.int64)
        self._tree = _kdray.Tree.build(
            np.ascontiguousarray(v), f, opts["layout"], opts["leaves"], opts["quality"], threads
        )
        self.watertight = bool(watertight)

    @classmethod
    def _wrap(cls, tree: Any, watertight: bool) -> "Scene":
        scene = cls.__new__(cls)
        scene._tree = tree
        scene.watertight = bool(watertight)
        return scene

    @classmethod
    def load(
        cls,
        path: "os.PathLike[str] | str",
        *,
        watertight: bool = False,
        threads: Optional[int] = None,
        **build_options: str,
    ) -> "Scene":
        """Loads a ``.kdt`` (a built tree, validated) or builds one from a mesh file: ``.ply``,
        ``.ply.gz``, ``.obj``, ``.tri`` (build options as for :class:`Scene`)."""
        opts = _build_options(build_options)
        threads = _threads(threads)
        try:
            path = os.fspath(path)
        except TypeError:
            raise TypeError(
                f"path must be a str or os.PathLike, not {type(path).__name__}"
            ) from None
        if not isinstance(path, str):
            raise TypeError(f"path must be a str or os.PathLike, not {type(path).__name__}")
        if not os.path.exists(path):
            raise FileNotFoundError(errno.ENOENT, "no such file", path)
        tree = _kdray.Tree.load(path, opts["layout"], opts["leaves"], opts["quality"], threads)
        return cls._wrap(tree, watertight)

    @classmethod
    def from_bytes(cls, data: bytes, *, watertight: bool = False) -> "Scene":
        """A scene from the bytes of a ``.kdt`` (as :meth:`to_bytes` gives them), validated."""
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise TypeError(f"data must be bytes, not {type(data).__name__}")
        size = memoryview(data).nbytes
        if size % 4:
            raise ValueError(
                f"data: {size} bytes: a .kdt is a whole number of 4-byte words (truncated?)"
            )
        # The words in place when the buffer is aligned, else copied once (the tree is copied
        # once more, onto cache lines, as it is validated).
        words = np.require(np.frombuffer(data, dtype="<u4"), requirements="CA")
        return cls._wrap(_kdray.Tree.from_words(words), watertight)

    def to_bytes(self) -> bytes:
        """The tree as the bytes of a ``.kdt`` file."""
        return self._tree.to_bytes()

    def save(self, path: "os.PathLike[str] | str") -> None:
        """Writes the tree as a ``.kdt`` file (whole or not at all), for :meth:`load` or the
        ``kdray`` command line."""
        self._tree.save(os.fspath(path))

    @property
    def info(self) -> dict:
        """``triangles``, ``nodes``, ``depth``, ``bounds`` (``(min, max)``), ``bytes``,
        ``layout``, ``leaves`` and ``build_ms``."""
        return self._tree.info()

    def __repr__(self) -> str:
        i = self.info
        return (
            f"kdray.Scene({i['triangles']} triangles, {i['nodes']} nodes, "
            f"{i['bytes']} bytes, watertight={self.watertight})"
        )

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
    ) -> Hits:
        """The closest hit of each ray ``origin + t·direction``, ``tmin < t < tmax``.

        ``origins`` and ``directions`` are ``(..., 3)`` and broadcast against each other and
        ``tmin``, ``tmax`` (numbers or arrays); directions need not be normalized, and ``t``
        is in units of their length. Returns :class:`Hits` of the broadcast shape.

        >>> import kdray
        >>> scene = kdray.Scene([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
        >>> hit = scene.intersect([0.5, 0.25, 2.0], [0, 0, -2], points=True)
        >>> float(hit.t), int(hit.prim), hit.points.tolist()
        (1.0, 0, [0.5, 0.25, 0.0])
        """
        b = _batch(origins, directions, tmin, tmax)
        t, prim, u, v, p, n = self._tree.intersect(
            b, self.watertight, bool(points), bool(normals), _threads(threads)
        )
        shape = b.shape
        return Hits(
            t.reshape(shape),
            prim.reshape(shape),
            u.reshape(shape),
            v.reshape(shape),
            None if p is None else p.reshape(shape + (3,)),
            None if n is None else n.reshape(shape + (3,)),
        )

    def raycast(
        self, origin: Any, direction: Any, tmin: float = 0.0, tmax: float = math.inf
    ) -> Tuple[float, int, float, float]:
        """One ray's closest hit as Python numbers, ``(t, prim, u, v)`` (``(inf, -1, 0.0, 0.0)``
        for a miss): the quick call for a ray at a time, with no arrays made. ``origin`` and
        ``direction`` are sequences of 3 numbers; answers as :meth:`intersect` gives them.

        >>> import kdray
        >>> kdray.Scene([[0, 0, 0], [1, 0, 0], [0, 1, 0]]).raycast((0.25, 0.5, 1), (0, 0, -1))
        (1.0, 0, 0.25, 0.5)
        """
        try:
            return self._tree.raycast(origin, direction, tmin, tmax, self.watertight)
        except (TypeError, ValueError) as e:
            for name, x in (("origin", origin), ("direction", direction)):
                if np.shape(x) != (3,):
                    raise TypeError(f"{name} must be 3 numbers, not {x!r}") from None
            for name, x in (("tmin", tmin), ("tmax", tmax)):
                if not isinstance(x, (int, float, np.number)):
                    raise TypeError(f"{name} must be a number, not {x!r}") from None
            # The batch's words for the one ray's arguments.
            msg = str(e)
            for batch, one in (("origins[0]", "origin"), ("directions[0]", "direction"),
                               ("tmin[0]", "tmin"), ("tmax[0]", "tmax"), ("ray 0: ", "")):
                msg = msg.replace(batch, one)
            raise type(e)(msg) from None

    def occluded(
        self,
        origins: Any,
        directions: Any,
        tmin: Any = 0.0,
        tmax: Any = math.inf,
        *,
        threads: Optional[int] = None,
    ) -> np.ndarray:
        """Whether any triangle lies along each ray in ``(tmin, tmax)``: a bool array (shadow
        rays: stop at the first hit found). Arguments as :meth:`intersect`."""
        b = _batch(origins, directions, tmin, tmax)
        out = self._tree.occluded(b, self.watertight, _threads(threads))
        return out.reshape(b.shape)

    def count_intersections(
        self,
        origins: Any,
        directions: Any,
        tmin: Any = 0.0,
        tmax: Any = math.inf,
        *,
        threads: Optional[int] = None,
    ) -> np.ndarray:
        """The number of times each ray crosses the surface in ``(tmin, tmax)`` (int64), exact:
        a ray through an edge or a vertex that triangles share counts one crossing, not one per
        triangle, and one that only touches counts none or two. Arguments as
        :meth:`intersect`."""
        b = _batch(origins, directions, tmin, tmax)
        out = self._tree.count(b, _threads(threads))
        return out.reshape(b.shape)

    def intersect_all(
        self,
        origins: Any,
        directions: Any,
        tmin: Any = 0.0,
        tmax: Any = math.inf,
        *,
        threads: Optional[int] = None,
    ) -> AllHits:
        """Every crossing of every ray, flattened (:class:`AllHits`: ray index, ``t``, triangle),
        exact as :meth:`count_intersections`. Arguments as :meth:`intersect`.

        >>> import kdray
        >>> floors = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1]]
        >>> scene = kdray.Scene(floors)  # two triangles, at z = 0 and z = 1
        >>> hits = scene.intersect_all([[0.2, 0.2, -1], [5, 5, -1], [0.1, 0.1, 3]], [0, 0, 1])
        >>> hits.ray.tolist(), hits.t.tolist(), hits.prim.tolist()
        ([0, 0], [1.0, 2.0], [0, 1])
        """
        b = _batch(origins, directions, tmin, tmax)
        ray, t, prim = self._tree.all(b, _threads(threads))
        return AllHits(ray, t, prim)

    def contains(self, points: Any, *, threads: Optional[int] = None) -> np.ndarray:
        """Whether each point lies inside the mesh, which should be closed (every edge shared by
        two triangles, as in a watertight trimesh): an odd number of exact crossings along
        :data:`CONTAINS_DIRECTION` (``+x``). Exact also where that ray passes through edges and
        vertices; a point on the surface may be either. ``points``: ``(..., 3)``; returns a bool
        array of the leading shape."""
        p, lead = _points(points, "points")
        out = self._tree.contains(
            np.ascontiguousarray(p.reshape(-1, 3)), _threads(threads)
        )
        return out.reshape(lead)
