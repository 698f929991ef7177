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

from . import _kdray, _pickle

__all__ = [
    "Scene", "Hits", "AllHits", "Instances", "InstanceHits", "CONTAINS_DIRECTION", "ISA",
    "MAX_THREADS", "__version__",
]

#: The axis along which :meth:`Scene.contains` casts its rays: ``+x``, or ``−x`` from a point
#: nearer the low x face of the scene's box (the parity is the same either way).
CONTAINS_DIRECTION = tuple(float(x) for x in _kdray.CONTAINS_DIRECTION)

#: The instruction set the extension's SIMD was compiled for, as ``kdray --version`` names it
#: (``'avx512f'``, ``'avx2+fma'``, ``'avx'``, ``'sse2'``, ...): a build from source compiles for
#: the CPU that builds it (the repository's ``.cargo/config.toml``), a portable wheel for SSE2.
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
_DEFAULTS = {"layout": "wide", "leaves": "list", "quality": "fast"}


class Hits(NamedTuple):
    """The closest hit of each ray (:meth:`Scene.intersect`); arrays of the batch's shape.

    ``t`` is ``inf`` for a miss and ``prim`` ``-1``; ``u``, ``v`` are the barycentric
    coordinates of the hit (``p = v0 + u·(v1 − v0) + v·(v2 − v0)``, 0 for a miss). ``points``
    (the hits, ``origin + t·direction``) and ``normals`` (the triangles' unit geometric normals,
    ``(v1 − v0) × (v2 − v0)`` normalized) have a trailing axis of 3, NaN for a miss, and are
    ``None`` unless asked for; ``points`` are float64 for a scene with an ``origin``.
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


#: The most threads a call may ask for (``threads=``): 16 a core.
MAX_THREADS: int = _kdray.MAX_THREADS


def _threads(threads: Any) -> Optional[int]:
    if threads is None:
        return None
    if isinstance(threads, (bool, np.bool_)):
        raise TypeError(f"threads must be an int or None, not {type(threads).__name__}")
    try:
        n = operator.index(threads)
    except TypeError:
        raise TypeError(
            f"threads must be an int or None, not {type(threads).__name__}"
        ) from None
    if not 1 <= n <= MAX_THREADS:
        raise ValueError(f"threads={n}: it must be from 1 to {MAX_THREADS} (16 a core)")
    return n


def _flag(x: Any, name: str) -> bool:
    """A yes/no option: ``True`` or ``False`` (numpy's too), not a string or a number."""
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    raise TypeError(f"{name} must be True or False, not {x!r} ({type(x).__name__})")


def _aligned(a: np.ndarray) -> np.ndarray:
    """``a`` C-contiguous and aligned: copied if it is not (``np.frombuffer`` at an odd offset,
    as a binary PLY's bytes give, is contiguous but not aligned)."""
    if a.flags.c_contiguous and a.flags.aligned:
        return a
    return np.array(a, order="C", copy=True)


def _index(i: Tuple[int, ...]) -> str:
    return "[" + ", ".join(str(int(k)) for k in i) + "]" if i else ""


def _float_array(x: Any, name: str, shift: Optional[np.ndarray] = None) -> np.ndarray:
    """``x`` as a float32 array: read in place when it is one (and aligned), converted once
    otherwise; minus ``shift`` (a scene's ``origin``, ``(3,)`` float64), in float64, before it is
    rounded. A finite value past float32's range is refused rather than made infinite, except
    for ``tmax``, where it means no bound."""
    if shift is None and type(x) is np.ndarray and x.dtype == np.float32 and x.flags.aligned:
        return x
    a = np.asarray(x)
    if a.dtype.kind not in "fiu":
        raise TypeError(f"{name} must hold numbers (float32 or float64), not {a.dtype}")
    if shift is not None:
        a = a.astype(np.float64) - shift
    elif a.dtype == np.float32:
        return _aligned(a)
    with np.errstate(over="ignore", invalid="ignore"):
        f = a.astype(np.float32)
    if a.dtype.kind == "f" and a.dtype.itemsize > 4:
        past = np.isinf(f) & np.isfinite(a)
        if name == "tmax":
            past &= a < 0
        if past.any():
            i = np.unravel_index(int(np.argmax(past)), a.shape)
            raise ValueError(
                f"{name}{_index(i)} is {float(a[i])!r}: past float32's range (about ±3.4e38)"
            )
    return f


def _points(
    x: Any, name: str, shift: Optional[np.ndarray] = None
) -> Tuple[np.ndarray, Tuple[int, ...]]:
    """An array of 3-vectors: ``(..., 3)``, as ``(k, 3)`` C-contiguous float32 and the leading
    shape (minus ``shift``, as :func:`_float_array`)."""
    a = _float_array(x, name, shift)
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


def _origin(origin: Any, vertices: Any) -> Optional[np.ndarray]:
    """A scene's ``origin`` as ``(3,)`` float64, or ``None``: ``'auto'`` is the centre of
    ``vertices``' bounding box."""
    if origin is None:
        return None
    if isinstance(origin, str):
        if origin != "auto":
            raise ValueError(f"origin={origin!r}: it must be 'auto', 3 numbers or None")
        if vertices is None:
            raise ValueError(
                "origin='auto' needs vertices: give a loaded tree the origin it was built with "
                "(Scene.origin)"
            )
        v = np.asarray(vertices)
        if v.dtype.kind not in "fiu" or v.ndim != 2 or v.shape[1] != 3 or len(v) == 0:
            return None  # the vertices' own checks say what is wrong
        v = v.astype(np.float64)
        centre = (v.min(axis=0) + v.max(axis=0)) / 2
        return centre if np.isfinite(centre).all() else None
    o = np.asarray(origin)
    if o.dtype.kind not in "fiu":
        raise TypeError(f"origin must be 3 numbers, 'auto' or None, not {origin!r}")
    if o.shape != (3,):
        raise ValueError(f"origin must have shape (3,), not {o.shape}")
    o = o.astype(np.float64)
    if not np.isfinite(o).all():
        raise ValueError(f"origin is {tuple(o.tolist())}: every coordinate must be finite")
    return o


class _Batch(NamedTuple):
    """What the extension's batch calls take (python/src/lib.rs, ``RayArgs``)."""

    origins: np.ndarray
    directions: np.ndarray
    tmin: np.ndarray
    tmax: np.ndarray
    n: int
    shape: Tuple[int, ...]


_F32_MAX = float(np.finfo(np.float32).max)


def _interval(x: Any, name: str) -> np.ndarray:
    if (type(x) is float or type(x) is int) and not -_F32_MAX <= x <= _F32_MAX:
        x = np.float64(x)  # checked for float32's range by _float_array
    if type(x) is float or type(x) is int:
        return np.array((x,), dtype=np.float32).reshape(())
    return _float_array(x, name)


def _batch(
    origins: Any, directions: Any, tmin: Any, tmax: Any, shift: Optional[np.ndarray] = None
) -> _Batch:
    o, o_lead = _points(origins, "origins", shift)
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

    ``Scene(vertices, faces=None, *, watertight=False, threads=None, origin=None,
    layout='wide', leaves='list', quality='fast')``

    - ``vertices``: ``(N, 3)`` floats (float32 is used as given, float64 converted once: the
      tree and the walks are float32, see ``origin``).
    - ``faces``: ``(M, 3)`` integer vertex indices; ``None``: every 3 vertices are a triangle.
    - ``watertight``: trace :meth:`intersect` and :meth:`occluded` with the watertight triangle
      test and a conservative walk, so that no ray slips between triangles that share an edge
      (slower); :meth:`count_intersections`, :meth:`intersect_all` and :meth:`contains` are
      always exact.
    - ``threads``: the threads the build uses (default: every core; at most
      :data:`MAX_THREADS`).
    - ``origin``: ``None``, 3 numbers or ``'auto'`` (the centre of the vertices' bounding box).
      Everything is traced in float32, whose spacing at 5·10⁶ (UTM coordinates) is 0.5: float64
      vertices and rays there are rounded by up to 0.25, and rays hit or miss otherwise than in
      float64. With an origin, the vertices, and every ray origin and point passed later, have
      it subtracted in float64 before they are rounded, so only their offsets from it are
      rounded; hit points, ``contains``' points and ``info['bounds']`` are in the caller's
      coordinates (points as float64), ``t`` is unchanged. :attr:`origin` holds it; a saved
      tree does not, so pass it to :meth:`load` or :meth:`from_bytes` again.
    - build options: ``layout`` (``'wide'``: also store the tree as eight-wide nodes with tight
      boxes, which single rays walk faster; or ``'nodes'``: the binary nodes only, a smaller
      tree), ``leaves`` (``'list'``: index lists, whose triangles the walk gathers four at a
      time into one SIMD test; or ``'groups'``: the triangles copied four to a group, faster
      single rays for two to four times the memory) and ``quality`` (``'fast'``: binned planes,
      a triangle referenced at most twice over along a path, past the depth limit only nodes
      of more than 32 triangles split — the build for a first answer; or ``'high'``: the exact sweep at every node and level, a
      build several times slower of a tree that traces faster — with ``leaves='groups'`` the
      choice for many millions of rays; docs/BUILD.md, "The first answer"), as
      ``kdray build --layout/--leaves/--quality``.

    Triangles are reported by their index in ``faces`` (input order). Degenerate triangles are
    kept in the numbering and never hit. Bad input raises ``ValueError`` (values) or
    ``TypeError`` (types) naming the argument.

    Example (and a mesh far from the origin, traced around its centre)::

        >>> import numpy as np, kdray
        >>> far = kdray.Scene([[5e6, 0, 0], [5e6 + 1, 0, 0], [5e6, 1, 0]], origin="auto")
        >>> float(far.intersect([5e6 + 0.3, 0.3, 1.0], [0, 0, -1]).t)
        1.0
        >>> v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
        >>> tetra = kdray.Scene(v, [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
        >>> tetra.contains([[0.1, 0.1, 0.1], [1.0, 1.0, 1.0]]).tolist()
        [True, False]
    """

    __slots__ = ("_tree", "watertight", "origin")

    def __init__(
        self,
        vertices: Any,
        faces: Any = None,
        *,
        watertight: bool = False,
        threads: Optional[int] = None,
        origin: Any = None,
        **build_options: str,
    ) -> None:
        opts = _build_options(build_options)
        threads = _threads(threads)
        watertight = _flag(watertight, "watertight")
        shift = _origin(origin, vertices)
        v = _float_array(vertices, "vertices", shift)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ValueError(f"vertices must have shape (N, 3), not {v.shape}")
        f = None
        if faces is not None:
            f = np.asarray(faces)
            if f.size == 0 and f.dtype.kind == "f":
                f = f.astype(np.int64)  # [] is float64 to numpy: no faces, not float faces
            if f.dtype.kind not in "iu":
                raise TypeError(f"faces must hold integers, not {f.dtype}")
            if f.ndim != 2 or f.shape[1] != 3:
                if f.size == 0:
                    f = f.reshape(0, 3)
                else:
                    raise ValueError(f"faces must have shape (M, 3), not {f.shape}")
            if f.dtype.kind == "u" and f.size and f.max() > np.iinfo(np.int64).max:
                raise ValueError(f"faces holds {f.max()}, past any vertex index")
            f = _aligned(np.asarray(f, dtype=np.int64))
        self._tree = _kdray.Tree.build(
            _aligned(v), f, opts["layout"], opts["leaves"], opts["quality"], threads
        )
        self.watertight = watertight
        self.origin = shift

    @classmethod
    def _wrap(cls, tree: Any, watertight: Any, origin: Any = None) -> "Scene":
        watertight = _flag(watertight, "watertight")
        shift = _origin(origin, None)
        scene = cls.__new__(cls)
        scene._tree = tree
        scene.watertight = watertight
        scene.origin = shift
        return scene

    @classmethod
    def load(
        cls,
        path: "os.PathLike[str] | str",
        *,
        watertight: bool = False,
        threads: Optional[int] = None,
        origin: Any = None,
        mmap: bool = False,
        **build_options: str,
    ) -> "Scene":
        """Loads a ``.kdt`` (a built tree, validated) or builds one from a mesh file: ``.ply``,
        ``.ply.gz``, ``.obj``, ``.tri`` (build options as for :class:`Scene`). A ``.kdt`` is
        loaded as it was built: build options are refused for it. ``origin``: for a ``.kdt``
        saved from a scene built with one (:attr:`Scene.origin`), that origin (the file does not
        hold it); a mesh file is read in float32, so it takes none.

        ``mmap=True`` maps a ``.kdt`` read-only instead of reading it: the processes of a host
        that map the same file share its pages (one copy of the tree in memory, whatever the
        number of workers). The file must then stay as it is while the scene lives (``save``
        replaces a file rather than rewriting it, which is safe); truncating it under a mapped
        scene is a crash, as with any memory map.
        """
        opts = _build_options(build_options)
        threads = _threads(threads)
        _flag(watertight, "watertight")
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
        if path.lower().endswith(".kdt"):
            if build_options:
                raise ValueError(
                    f"{', '.join(build_options)}: build options apply to mesh files; a .kdt is "
                    "loaded as it was built"
                )
        elif origin is not None:
            raise ValueError(
                "origin applies to a .kdt saved with one: a mesh file is read in float32 "
                "(build from its arrays in float64 with Scene(vertices, faces, origin=...))"
            )
        if mmap:
            if not path.lower().endswith(".kdt"):
                raise ValueError(
                    f"mmap=True maps a saved tree (.kdt), not a mesh file: {path}"
                )
            return cls._wrap(_kdray.map_kdt(path), watertight, origin)
        tree = _kdray.Tree.load(path, opts["layout"], opts["leaves"], opts["quality"], threads)
        return cls._wrap(tree, watertight, origin)

    @classmethod
    def from_bytes(
        cls, data: bytes, *, watertight: bool = False, origin: Any = None
    ) -> "Scene":
        """A scene from the bytes of a ``.kdt`` (as :meth:`to_bytes` gives them), validated;
        ``origin`` as for :meth:`load`."""
        _flag(watertight, "watertight")
        _origin(origin, None)
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
        return cls._wrap(_kdray.Tree.from_words(words), watertight, origin)

    def __reduce_ex__(self, protocol: Any) -> Any:
        """Pickles the tree's words (out of band with protocol 5), ``watertight`` and ``origin``;
        unpickling validates the words, never rebuilds (kdray/_pickle.py).

        >>> import pickle, kdray
        >>> scene = kdray.Scene([[0, 0, 0], [1, 0, 0], [0, 1, 0]], watertight=True)
        >>> pickle.loads(pickle.dumps(scene, protocol=5))
        kdray.Scene(1 triangles, 1 nodes, 512 bytes, watertight=True)
        """
        return _pickle.reduce(self, operator.index(protocol))

    def __copy__(self) -> "Scene":
        """A scene sharing this one's tree, which nothing changes once built (no copy), with its
        options."""
        return Scene._wrap(self._tree, self.watertight, self.origin)

    def __deepcopy__(self, memo: Any) -> "Scene":
        """As :meth:`__copy__`: the tree is immutable, so a deep copy shares it too."""
        return Scene._wrap(self._tree, self.watertight, self.origin)

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
        ``layout``, ``leaves`` and ``build_ms`` (``bounds`` in the caller's coordinates: with
        :attr:`origin` added back)."""
        info = self._tree.info()
        if self.origin is not None:
            lo, hi = info["bounds"]
            info["bounds"] = (
                (np.asarray(lo, dtype=np.float64) + self.origin).tolist(),
                (np.asarray(hi, dtype=np.float64) + self.origin).tolist(),
            )
        return info

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
        b = _batch(origins, directions, tmin, tmax, self.origin)
        t, prim, u, v, p, n = self._tree.intersect(
            b, self.watertight, _flag(points, "points"), _flag(normals, "normals"),
            _threads(threads)
        )
        if p is not None and self.origin is not None:
            p = (p.reshape(-1, 3) + self.origin).reshape(-1)
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
        if self.origin is not None and np.shape(origin) == (3,):
            origin = (np.asarray(origin, dtype=np.float64) - self.origin).tolist()
        try:
            return self._tree.raycast(origin, direction, tmin, tmax, self.watertight)
        except (TypeError, ValueError) as e:
            for name, x in (("origin", origin), ("direction", direction)):
                if np.shape(x) != (3,):
                    raise TypeError(f"{name} must be 3 numbers, not {x!r}") from None
            for name, x in (("tmin", tmin), ("tmax", tmax)):
                if not isinstance(x, (int, float, np.number)):
                    raise TypeError(f"{name} must be a number, not {x!r}") from None
            for name, x in (("origin", origin), ("direction", direction), ("tmin", tmin),
                            ("tmax", tmax)):
                try:
                    a = np.asarray(x, dtype=np.float64)
                except (TypeError, ValueError):
                    continue
                past = np.isfinite(a) & (np.abs(a) > _F32_MAX) & ((a < 0) | (name != "tmax"))
                if past.any():
                    raise ValueError(
                        f"{name} is {x!r}: past float32's range (about ±3.4e38)"
                    ) from None
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
        b = _batch(origins, directions, tmin, tmax, self.origin)
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
        b = _batch(origins, directions, tmin, tmax, self.origin)
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
        b = _batch(origins, directions, tmin, tmax, self.origin)
        ray, t, prim = self._tree.all(b, _threads(threads))
        return AllHits(ray, t, prim)

    def contains(self, points: Any, *, threads: Optional[int] = None) -> np.ndarray:
        """Whether each point lies inside the mesh, which should be closed (every edge shared by
        two triangles, as in a watertight trimesh): an odd number of exact crossings along
        the x axis (:data:`CONTAINS_DIRECTION`), towards the nearer x face of the scene's box
        (``+x`` or ``−x``: the same parity, half the walk). Exact also where that ray passes
        through edges and vertices; a point on the surface may be either. ``points``:
        ``(..., 3)``; returns a bool array of the leading shape."""
        p, lead = _points(points, "points", self.origin)
        out = self._tree.contains(_aligned(p.reshape(-1, 3)), _threads(threads))
        return out.reshape(lead)


# Scenes of many meshes (kdray/_instances.py), after Scene, which they are made of.
from ._instances import InstanceHits, Instances  # noqa: E402
