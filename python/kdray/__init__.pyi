"""Type stubs of :mod:`kdray` (docstrings and examples: kdray/__init__.py)."""

import os
from typing import Any, Iterable, List, Literal, NamedTuple, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__all__ = [
    "Scene", "Hits", "AllHits", "Instances", "InstanceHits", "CONTAINS_DIRECTION", "ISA",
    "MAX_THREADS", "__version__",
]

CONTAINS_DIRECTION: Tuple[float, float, float]
ISA: str
MAX_THREADS: int
__version__: str
_Origin = Union[None, str, npt.ArrayLike]

#: The build options' values (``kdray build --layout/--leaves/--quality``).
Layout = Literal["wide", "nodes"]
Leaves = Literal["groups", "list"]
Quality = Literal["fast", "high"]

_Path = Union[str, "os.PathLike[str]"]
_Floats = npt.ArrayLike

class Hits(NamedTuple):
    t: npt.NDArray[np.float32]
    prim: npt.NDArray[np.int64]
    u: npt.NDArray[np.float32]
    v: npt.NDArray[np.float32]
    points: Optional[npt.NDArray[Any]] = ...
    normals: Optional[npt.NDArray[np.float32]] = ...

class AllHits(NamedTuple):
    ray: npt.NDArray[np.int64]
    t: npt.NDArray[np.float32]
    prim: npt.NDArray[np.int64]

class Scene:
    watertight: bool
    origin: Optional[npt.NDArray[np.float64]]
    def __init__(
        self,
        vertices: _Floats,
        faces: Optional[npt.ArrayLike] = None,
        *,
        watertight: bool = False,
        threads: Optional[int] = None,
        origin: _Origin = None,
        layout: Layout = "wide",
        leaves: Leaves = "list",
        quality: Quality = "fast",
    ) -> None: ...
    @classmethod
    def load(
        cls,
        path: _Path,
        *,
        watertight: bool = False,
        threads: Optional[int] = None,
        origin: _Origin = None,
        mmap: bool = False,
        layout: Layout = "wide",
        leaves: Leaves = "list",
        quality: Quality = "fast",
    ) -> "Scene": ...
    @classmethod
    def from_bytes(
        cls,
        data: Union[bytes, bytearray, memoryview],
        *,
        watertight: bool = False,
        origin: _Origin = None,
    ) -> "Scene": ...
    def __reduce_ex__(self, protocol: int) -> Tuple[Any, Tuple[Any, bool]]: ...
    def __copy__(self) -> "Scene": ...
    def __deepcopy__(self, memo: Any) -> "Scene": ...
    def to_bytes(self) -> bytes: ...
    def save(self, path: _Path) -> None: ...
    @property
    def info(self) -> dict[str, Any]: ...
    def intersect(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Floats = 0.0,
        tmax: _Floats = ...,
        *,
        points: bool = False,
        normals: bool = False,
        threads: Optional[int] = None,
    ) -> Hits: ...
    def raycast(
        self, origin: npt.ArrayLike, direction: npt.ArrayLike, tmin: float = 0.0, tmax: float = ...
    ) -> Tuple[float, int, float, float]: ...
    def occluded(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Floats = 0.0,
        tmax: _Floats = ...,
        *,
        threads: Optional[int] = None,
    ) -> npt.NDArray[np.bool_]: ...
    def count_intersections(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Floats = 0.0,
        tmax: _Floats = ...,
        *,
        threads: Optional[int] = None,
    ) -> npt.NDArray[np.int64]: ...
    def intersect_all(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Floats = 0.0,
        tmax: _Floats = ...,
        *,
        threads: Optional[int] = None,
    ) -> AllHits: ...
    def contains(
        self, points: _Floats, *, threads: Optional[int] = None
    ) -> npt.NDArray[np.bool_]: ...

class InstanceHits(NamedTuple):
    t: npt.NDArray[np.float32]
    prim: npt.NDArray[np.int64]
    u: npt.NDArray[np.float32]
    v: npt.NDArray[np.float32]
    geometry_id: npt.NDArray[np.int64]
    instance_id: npt.NDArray[np.int64]
    points: Optional[npt.NDArray[np.float32]] = ...
    normals: Optional[npt.NDArray[np.float32]] = ...

#: A mesh for :class:`Instances`: a Scene, ``(vertices, faces)``, or an object with
#: ``vertices`` and ``faces`` (a ``trimesh.Trimesh``).
_Mesh = Any
#: ``None`` (once, as it is), ``(4, 4)`` / ``(3, 4)``, or ``(k, 4, 4)`` / ``(k, 3, 4)``.
_Transforms = Optional[npt.ArrayLike]

class Instances:
    watertight: bool
    merge: bool
    def __init__(
        self,
        meshes: Iterable[_Mesh] = ...,
        transforms: Optional[Iterable[_Transforms]] = None,
        *,
        watertight: bool = False,
        merge: bool = False,
        threads: Optional[int] = None,
        layout: Layout = "wide",
        leaves: Leaves = "list",
        quality: Quality = "fast",
    ) -> None: ...
    def add_mesh(self, mesh: _Mesh, transforms: _Transforms = None) -> int: ...
    def remove_mesh(self, geometry_id: int) -> None: ...
    def set_transforms(self, geometry_id: int, transforms: _Transforms) -> None: ...
    def transforms(self, geometry_id: int) -> npt.NDArray[np.float64]: ...
    def mesh(self, geometry_id: int) -> Scene: ...
    @property
    def geometry_ids(self) -> List[int]: ...
    def __len__(self) -> int: ...
    @property
    def info(self) -> dict[str, Any]: ...
    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]: ...
    def intersect(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Floats = 0.0,
        tmax: _Floats = ...,
        *,
        points: bool = False,
        normals: bool = False,
        threads: Optional[int] = None,
    ) -> InstanceHits: ...
    def raycast(
        self, origin: npt.ArrayLike, direction: npt.ArrayLike, tmin: float = 0.0, tmax: float = ...
    ) -> Tuple[float, int, float, float, int, int]: ...
    def occluded(
        self,
        origins: _Floats,
        directions: _Floats,
        tmin: _Floats = 0.0,
        tmax: _Floats = ...,
        *,
        threads: Optional[int] = None,
    ) -> npt.NDArray[np.bool_]: ...
