"""Type stubs of :mod:`kdray.trimesh` (docstrings: kdray/trimesh.py)."""

from typing import Any, List, NamedTuple, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import Instances, Scene

class RayMeshIntersector:
    mesh: Any
    def __init__(self, mesh: Any, *, watertight: bool = False, **build_options: Any) -> None: ...
    @property
    def scene(self) -> Scene: ...
    def intersects_first(
        self, ray_origins: npt.ArrayLike, ray_directions: npt.ArrayLike, **kwargs: Any
    ) -> npt.NDArray[np.int64]: ...
    def intersects_any(
        self, ray_origins: npt.ArrayLike, ray_directions: npt.ArrayLike, **kwargs: Any
    ) -> npt.NDArray[np.bool_]: ...
    def intersects_id(
        self,
        ray_origins: npt.ArrayLike,
        ray_directions: npt.ArrayLike,
        return_locations: bool = False,
        multiple_hits: bool = True,
        **kwargs: Any,
    ) -> Union[
        Tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]],
        Tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64]],
    ]: ...
    def intersects_location(
        self,
        ray_origins: npt.ArrayLike,
        ray_directions: npt.ArrayLike,
        multiple_hits: bool = True,
        **kwargs: Any,
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64]]: ...
    def contains_points(self, points: npt.ArrayLike) -> npt.NDArray[np.bool_]: ...

class SceneInstances(NamedTuple):
    instances: Instances
    geometry_names: List[str]
    node_names: List[List[str]]

def instances(scene: Any, *, watertight: bool = False, **build_options: Any) -> SceneInstances: ...
