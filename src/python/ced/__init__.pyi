# SPDX-License-Identifier: MIT
# Type stubs of the package `ced` (docs/PYTHON.md is the reference).
from os import PathLike
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import eval as eval

__version__: str

class FileError(OSError):
    """A file that cannot be read or written: missing, malformed, truncated, unsupported."""

class PluginError(ImportError):
    """A plugin that cannot be loaded; the message names the file and says why."""

class Cloud:
    """A point cloud: positions (float32, relative to `origin`) and named per-point fields in their own dtypes."""

    def __init__(self, points: PointsLike, channels: Optional[Channels] = None) -> None: ...
    def __len__(self) -> int: ...
    @property
    def points(self) -> npt.NDArray[np.float32]:
        """(N, 3) float32 view of the positions, relative to `origin` (no copy, read-only)."""
    @property
    def origin(self) -> Tuple[float, float, float]:
        """The point that positions are relative to (non-zero for georeferenced data)."""
    def absolute_points(self) -> npt.NDArray[np.float64]:
        """(N, 3) float64 copy of the absolute positions: origin + points."""
    @property
    def fields(self) -> Dict[str, np.ndarray]:
        """Dict name -> (N,) array viewing each field in its own dtype (no copy, read-only)."""
    def select(self, indices: npt.ArrayLike) -> Cloud:
        """A new cloud of the points `indices` names, fields included."""

class Modality:
    """A modality: a channel and its saliency measure."""

    def __init__(self, spec: str) -> None:
        """From a spec string, the CLI's grammar: 'xyz:0.2', 'bands(nir,red):0.1,range=0..255'."""
    @property
    def name(self) -> str: ...
    @property
    def fields(self) -> Optional[List[str]]:
        """The fields it reads (None: it does not say; []: positions only)."""
    def threshold(self, radius: float = 0.05) -> float:
        """The absolute threshold at `radius` (xyz: ratio x radius)."""

class Result:
    """What ced.detect found, and why. Arrays are read-only views of the C++ result (no copy)."""

    @property
    def keypoints(self) -> npt.NDArray[np.uint32]:
        """Keypoint indices into the input, ascending."""
    @property
    def rank_score(self) -> npt.NDArray[np.float32]:
        """(K,), one per keypoint: what max_keypoints ranks it by, its score (the product of its saliencies),
        or refined, the highest score of the maxima refined onto it."""
    @property
    def saliency(self) -> Dict[str, npt.NDArray[np.float32]]:
        """Modality name -> (N,) saliency of every point (0 below min_neighbors)."""
    @property
    def candidate(self) -> npt.NDArray[np.bool_]:
        """(N,): some modality reaches its threshold."""
    @property
    def neighbor_count(self) -> npt.NDArray[np.uint32]:
        """(N,): neighbours within the radius, the point itself included."""
    @property
    def point_radius(self) -> Optional[npt.NDArray[np.float32]]:
        """(N,): each point's own radius under a knn or adaptive neighbourhood; None for the fixed radius."""
    @property
    def thresholds(self) -> Dict[str, float]:
        """Modality name -> absolute threshold (xyz: ratio x radius)."""
    @property
    def names(self) -> List[str]:
        """The modality names, in order (a repeated name gets '#2', ...)."""
    @property
    def times(self) -> Dict[str, float]:
        """Stage times in milliseconds: index_ms, saliency_ms, nms_ms, total_ms."""
    @property
    def radius(self) -> float: ...
    @property
    def nms_radius(self) -> float: ...
    @property
    def min_neighbors(self) -> int: ...
    @property
    def refine(self) -> bool: ...
    @property
    def max_keypoints(self) -> int: ...
    @property
    def keypoint_share(self) -> float: ...
    def __len__(self) -> int: ...

PointsLike = Union[npt.ArrayLike, Cloud, Any]  # (N, 3) floats, a structured array, a Cloud, an Open3D cloud
Channels = Union[Mapping[str, npt.ArrayLike], np.ndarray]  # a dict of arrays, or a structured array
ModalityLike = Union[str, Modality]
BlockFunction = Callable[[npt.NDArray[np.uint32], npt.NDArray[np.int64], npt.NDArray[np.uint32]], npt.ArrayLike]
PointFunction = Callable[[int, npt.NDArray[np.uint32]], float]

def detect(
    points: PointsLike,
    channels: Optional[Channels] = None,
    modalities: Union[None, str, Modality, Iterable[ModalityLike]] = None,
    radius: Union[float, str] = 0.05,
    nms_radius: Optional[float] = None,
    min_neighbors: int = 5,
    threads: int = 0,
    radius_factor: float = 5.0,
    refine: Optional[bool] = None,
    max_keypoints: int = 0,
    neighborhood: str = "radius",
    search: str = "grid",
    keypoint_share: Optional[float] = None,
) -> Result:
    """Detects keypoints (see docs/PYTHON.md). Releases the GIL; Ctrl-C raises KeyboardInterrupt."""

def read(path: str, fields: Optional[Sequence[str]] = None, format: Optional[str] = None) -> Cloud:
    """Reads a PLY, PCD, LAS or CSV file (only `fields` when given)."""

def write(path: str, cloud: PointsLike, channels: Optional[Channels] = None, format: Optional[str] = None) -> None:
    """Writes a cloud atomically; the format from the extension unless given."""

def write_keypoints(path: str, cloud: PointsLike, result: Result, format: Optional[str] = None) -> None:
    """Writes the keypoints with their fields and saliency_<modality> fields, as `ced detect -o`."""

def render(path: str, cloud: PointsLike, keypoints: Optional[npt.ArrayLike] = None, view: str = "iso",
           width: int = 1280, height: int = 960) -> None:
    """Draws the cloud and its keypoints into a PNG file. view: 'iso', 'top' or 'front'."""

def estimate_resolution(cloud: PointsLike) -> float:
    """The median nearest-neighbour distance over up to 20000 evenly spread points."""

def estimate_normals(cloud: PointsLike, radius: float, threads: int = 0) -> npt.NDArray[np.float32]:
    """Unit normals (N x 3) by PCA within `radius`, unoriented."""

def voxel_downsample(cloud: PointsLike, size: float) -> Cloud:
    """Voxel-grid down-sampling as PCL's VoxelGrid (positions and fields averaged)."""

def modality(spec: str) -> Modality:
    """A modality from a spec string."""

def __getattr__(name: str) -> Callable[..., Modality]:
    """A built-in modality with no helper listed here (ced/modalities/builtin.hpp): ced.<name>(threshold=None,
    fields=None, **options)."""

def xyz(threshold: float = 0.2) -> Modality:
    """Geometry: L2 distance to the neighbours' centroid; threshold is a ratio of the radius."""

def rgb(threshold: float = 0.1, norm: Optional[str] = None,
        range: Union[None, str, Tuple[float, float]] = None) -> Modality:
    """Colour: L1 distance to the neighbours' mean colour, channels scaled to [0, 1]."""

def lab(threshold: Optional[float] = None) -> Modality:
    """Colour in CIELAB (perceptual distance, ΔE*76 / 100): the colour fields as rgb reads them."""

def normals(threshold: Optional[float] = None, radius: Optional[float] = None,
            source: Optional[str] = None) -> Modality:
    """Surface normals (the orientation tensor n n^T), read from nx, ny, nz or estimated."""

def intensity(threshold: Optional[float] = None, field: Optional[str] = None,
              range: Union[None, str, Tuple[float, float]] = None) -> Modality:
    """A scalar field (default 'intensity')."""

def bands(fields: Union[str, Sequence[str]], threshold: float = 0.1, norm: Optional[str] = None,
          range: Union[None, str, Tuple[float, float]] = None) -> Modality:
    """Several scalar fields as one channel (multispectral bands)."""

def python_modality(name: str, fn: Union[BlockFunction, PointFunction], threshold: float,
                    per_point: bool = False) -> Modality:
    """A modality whose saliency a Python function computes (slow; for prototyping). Saliencies must be finite
    and >= 0 (else ValueError); the function may itself call ced.detect (run single-threaded)."""

def preset_names() -> List[str]:
    """The presets' names: ced3d, ced6d, robust3d, robust6d, corner3d."""

def preset_refines(name: str) -> bool:
    """Whether a preset refines its keypoints: robust3d, robust6d and corner3d do, ced3d and ced6d not."""

def preset_keypoint_share(name: str) -> float:
    """The share of the candidates a preset keeps at most as keypoints (detect(keypoint_share=...)): 0.01 for
    robust3d and robust6d, whose counts would otherwise grow with noise; 0 (no limit) for the others."""

def preset(name: str) -> List[Modality]:
    """'ced3d' (xyz:0.2), 'ced6d' (xyz:0.2, rgb:0.1), 'robust3d' (xyz:0.2,scale=2), 'robust6d'
    (xyz:0.2,scale=2.25,inner=1, rgb:0.5) or 'corner3d' (corner:0.05, corner:0.05,scale=1.5). The robust presets and corner3d also refine
    their keypoints (ced.preset_refines).
    The list remembers the preset: detect() and plan_tiles() given it unchanged run the preset, its refinement
    and keypoint share included."""

def modalities() -> List[Tuple[str, str]]:
    """(name, help) of every registered modality, sorted."""

def load_plugin(path: str) -> List[str]:
    """Loads a plugin and returns the modalities it added."""

def release_cached_memory() -> None:
    """Frees the up to 32 MiB that detections keep cached for the next one."""


class TilePlan:
    """The tiles of a cloud file (the plan of `ced plan`); pickles as its JSON."""

    @staticmethod
    def from_json(text: str) -> "TilePlan": ...
    @staticmethod
    def load(path: str) -> "TilePlan": ...
    def to_json(self) -> str: ...
    def save(self, path: Union[str, PathLike[str]]) -> None:
        """Writes the plan as JSON (atomically); never over the plan's input (ValueError)."""
    @property
    def input(self) -> str: ...
    @property
    def modalities(self) -> List[str]: ...
    @property
    def radius(self) -> float: ...
    @property
    def neighborhood(self) -> str:
        """The tiles' neighbourhood spec, with the reach they take ('knn:16,reach=0.43')."""
    @property
    def reach_estimated(self) -> bool:
        """True when the neighbourhood's reach= is ced's estimate from the cloud's density (knn:K, or adaptive:K
        without max, planned without reach=)."""
    @property
    def tile_size(self) -> float: ...
    @property
    def halo(self) -> float: ...
    @property
    def points(self) -> int: ...
    @property
    def digest(self) -> str: ...
    @property
    def indexed(self) -> bool:
        """True when planned from the file's COPC index without a pass over the points (tile counts are
        estimates)."""
    @property
    def tiles(self) -> List[Tuple[int, int, int]]:
        """(id, points owned, points read) of every tile that owns points."""


class TilePart:
    """The keypoints one tile contributes (or, merged, the whole cloud's)."""

    @property
    def tile(self) -> int: ...
    @property
    def keypoints(self) -> npt.NDArray[np.uint64]:
        """Indices into the file's finite points, ascending."""
    @property
    def file_indices(self) -> npt.NDArray[np.uint64]: ...
    @property
    def cloud(self) -> Cloud: ...
    @property
    def saliency(self) -> Dict[str, npt.NDArray[np.float32]]: ...
    @property
    def rank(self) -> npt.NDArray[np.float32]:
        """What each keypoint ranks by when the merge keeps the strongest (Result.rank_score)."""
    @property
    def thresholds(self) -> Dict[str, float]: ...
    @property
    def detect_ms(self) -> float: ...
    def write(self, plan: TilePlan, path: Union[str, PathLike[str]]) -> None:
        """Writes the part file; `plan` must be its own and `path` not the plan's input (ValueError)."""


def plan_tiles(input: str, tile_size: Optional[float] = None, memory_limit: Optional[float] = None,
               modalities: Union[None, str, Sequence[str]] = None, radius: float = 0.05,
               nms_radius: Optional[float] = None, min_neighbors: int = 5, format: str = "auto",
               refine: Optional[bool] = None, max_keypoints: int = 0, scan: bool = False,
               neighborhood: str = "radius", search: str = "grid",
               keypoint_share: Optional[float] = None) -> TilePlan:
    """Plans the tiles of a cloud file (two passes over it), as `ced plan`. tile_size (metres, > 0) or
    memory_limit (bytes, 1 .. 1e18), not both. A COPC file is planned from its index and header without a
    pass over the points (plan.indexed), unless scan=True or memory_limit is given. neighborhood and search
    as detect()'s; tiles need a bounded reach: 'adaptive:K,...,max=r1', or 'knn:K,reach=R' /
    'adaptive:K,...,reach=R', which detect_tile checks (RuntimeError when a point reaches farther)."""


def detect_tile(plan: TilePlan, tile: int, part: Union[None, str, PathLike[str]] = None,
                threads: int = 0) -> TilePart:
    """Reads and detects one tile of the plan's input; writes its part to `part` when given (never over the
    plan's input: ValueError)."""


def read_part(plan: TilePlan, path: str) -> TilePart: ...


def merge_parts(plan: TilePlan, parts: Iterable[Union[str, TilePart]]) -> TilePart:
    """Every tile's part merged: exactly the keypoints of a whole-cloud detection."""
