"""The extension module behind :mod:`kdray` (Rust: python/src/). Called by kdray/__init__.py
with arrays it has checked and converted: C-contiguous float32 rays (one row, shared, or n),
int64 faces. Not a public API."""

from typing import List, Literal, Optional, Tuple

import numpy as np
import numpy.typing as npt

CONTAINS_DIRECTION: Tuple[float, float, float]
ISA: str
MAX_THREADS: int

F32 = npt.NDArray[np.float32]
I64 = npt.NDArray[np.int64]
# origins, directions (k, 3), tmin, tmax (k,) with k = 1 or n, n, the batch's shape.
Rays = Tuple[F32, F32, F32, F32, int, Tuple[int, ...]]

class Tree:
    @staticmethod
    def build(
        vertices: F32,
        faces: Optional[I64],
        layout: Literal["wide", "nodes"],
        leaves: Literal["groups", "list"],
        quality: Literal["fast", "high"],
        threads: Optional[int],
    ) -> "Tree": ...
    @staticmethod
    def load(
        path: str,
        layout: Literal["wide", "nodes"],
        leaves: Literal["groups", "list"],
        quality: Literal["fast", "high"],
        threads: Optional[int],
    ) -> "Tree": ...
    @staticmethod
    def from_words(words: npt.NDArray[np.uint32]) -> "Tree": ...
    def to_bytes(self) -> bytes: ...
    def save(self, path: str) -> None: ...
    def moved(self, transforms: F32) -> "Top": ...
    def info(self) -> dict: ...
    def raycast(
        self, origin: Tuple[float, float, float], direction: Tuple[float, float, float],
        tmin: float, tmax: float, watertight: bool,
    ) -> Tuple[float, int, float, float]: ...
    def intersect(
        self, rays: Rays, watertight: bool, points: bool, normals: bool, threads: Optional[int]
    ) -> Tuple[F32, I64, F32, F32, Optional[F32], Optional[F32]]: ...
    def occluded(
        self, rays: Rays, watertight: bool, threads: Optional[int]
    ) -> npt.NDArray[np.bool_]: ...
    def count(self, rays: Rays, threads: Optional[int]) -> I64: ...
    def all(self, rays: Rays, threads: Optional[int]) -> Tuple[I64, F32, I64]: ...
    def contains(self, points: F32, threads: Optional[int]) -> npt.NDArray[np.bool_]: ...

# The tree's words in place, read-only (pickle: kdray/_pickle.py).
def words(tree: Tree) -> npt.NDArray[np.uint32]: ...
# A .kdt mapped read-only and validated (Scene.load(path, mmap=True)).
def map_kdt(path: str) -> Tree: ...

# A top level over trees (kdray.Instances, kdray/_instances.py; src/instanced.rs).
class Top:
    @staticmethod
    def build(
        trees: List[Tree], bottom: npt.NDArray[np.uint32], transforms: F32, geometry: I64,
        instance: I64,
    ) -> "Top": ...
    def moved(self, transforms: F32) -> "Top": ...
    def info(self) -> dict: ...
    def raycast(
        self, origin: Tuple[float, float, float], direction: Tuple[float, float, float],
        tmin: float, tmax: float, watertight: bool,
    ) -> Tuple[float, int, float, float, int, int]: ...
    def intersect(
        self, rays: Rays, watertight: bool, points: bool, normals: bool, threads: Optional[int]
    ) -> Tuple[F32, I64, F32, F32, I64, I64, Optional[F32], Optional[F32]]: ...
    def occluded(
        self, rays: Rays, watertight: bool, threads: Optional[int]
    ) -> npt.NDArray[np.bool_]: ...

# A batch's rays checked as the batch calls check them (a scene of no instances).
def check_rays(rays: Rays) -> None: ...
# One tree over the trees' triangles, in order (kdray.Instances(..., merge=True)).
def merge(
    trees: List[Tree], layout: Literal["wide", "nodes"], leaves: Literal["groups", "list"],
    quality: Literal["fast", "high"], threads: Optional[int],
) -> Tree: ...
# A merged tree's triangles (rewritten in place) as (mesh's triangle, geometry ids, instance ids).
def merged_ids(
    prim: npt.NDArray[np.int64], first: npt.NDArray[np.int64], ids: npt.NDArray[np.int64]
) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
