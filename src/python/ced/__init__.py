# SPDX-License-Identifier: MIT
"""ced: N-modal CEntroid Distance keypoint detection in point clouds.

The C++ detector (Teng et al., WACV 2023, generalised to any per-point
channels) over numpy arrays, Open3D clouds and files. docs/PYTHON.md is the
reference; the common case is one call::

    import ced
    cloud = ced.read("scan.ply")
    result = ced.detect(cloud)                   # ced6d if it has colour, else ced3d
    print(result.keypoints, result.saliency["xyz"])
"""

import atexit

from ._ced import (
    Cloud,
    FileError,
    Modality,
    PluginError,
    Result,
    TilePart,
    TilePlan,
    __version__,
    detect_tile,
    load_plugin,
    merge_parts,
    modalities,
    plan_tiles,
    preset_names,
    preset_keypoint_share,
    preset_refines,
    python_modality,
    read,
    read_part,
    release_cached_memory,
)
from ._ced import _detect, write as _write
from . import _ced
from . import eval  # noqa: F401  (ced.eval.repeatability)

# A daemon thread still inside ced's C++ work when the interpreter exits would
# be stopped in it and abort the process: exit waits for that work instead.
atexit.register(_ced._wait_for_released_calls)

__all__ = [
    "Cloud", "FileError", "Modality", "PluginError", "Result", "TilePart", "TilePlan", "__version__", "bands",
    "detect", "detect_tile", "estimate_normals", "estimate_resolution", "eval", "intensity", "lab", "load_plugin", "merge_parts",
    "modalities", "modality", "normals", "plan_tiles", "preset", "preset_names", "preset_keypoint_share", "preset_refines", "python_modality", "read", "read_part",
    "release_cached_memory", "render", "rgb", "voxel_downsample", "write", "write_keypoints", "xyz",
]


def _number(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TypeError(f"{name}: expected a number, got {type(value).__name__}")
    return repr(float(value))


def _spec(name, threshold, args=None, **options):
    text = name
    if args is not None:
        if isinstance(args, str):
            args = [args]
        for a in args:
            if not isinstance(a, str) or not a or any(c in a for c in "(),:"):
                raise ValueError(f"{name}: bad field name {a!r}")
        text += "(" + ",".join(args) + ")"
    if threshold is not None:
        text += ":" + _number(threshold, "threshold")
    for key, value in options.items():
        if value is None:
            continue
        if key == "range" and not isinstance(value, str):
            lo, hi = value
            value = f"{_number(lo, 'range')}..{_number(hi, 'range')}"
        text += f",{key}={value}"
    return Modality(text)


def modality(spec):
    """A modality from a spec string, the CLI's grammar: 'xyz:0.2', 'bands(nir,red):0.1,range=0..255'."""
    return Modality(spec)


def xyz(threshold=0.2):
    """Geometry: L2 distance to the neighbours' centroid; threshold is a ratio of the radius."""
    return _spec("xyz", threshold)


def rgb(threshold=0.1, norm=None, range=None):
    """Colour: L1 distance to the neighbours' mean colour, channels scaled to [0, 1]."""
    return _spec("rgb", threshold, norm=norm, range=range)


def lab(threshold=None):
    """Colour in CIELAB (perceptual distance, ΔE*76 / 100): the colour fields as rgb reads them."""
    return _spec("lab", threshold)


def normals(threshold=None, radius=None, source=None):
    """Surface normals: distance of a point's normal axis (n n^T) to its neighbours' mean. Normals come from the
    fields nx, ny, nz when present, else by PCA within `radius` x the detection radius (0 < radius <= 1);
    `source` is 'auto', 'fields' or 'estimate'."""
    return _spec("normals", threshold, radius=None if radius is None else _number(radius, "radius"), **{"from": source})


def intensity(threshold=None, field=None, range=None):
    """A scalar field (default 'intensity'), scaled by its type's range or `range` ('auto', (lo, hi))."""
    return _spec("intensity", threshold, field, range=range)


def bands(fields, threshold=0.1, norm=None, range=None):
    """Several scalar fields as one channel (multispectral bands): bands(["nir", "red"], 0.1)."""
    fields = [fields] if isinstance(fields, str) else list(fields)
    if not fields:
        raise ValueError("bands: give at least one field name")
    return _spec("bands", threshold, fields, norm=norm, range=range)


def _builtin_helper(name, help_text):
    def helper(threshold=None, fields=None, **options):
        return _spec(name, threshold, fields, **options)

    helper.__name__ = helper.__qualname__ = name
    helper.__doc__ = (f"{help_text}. ced.{name}(threshold=None, fields=None, **options) makes the spec "
                      f"'{name}[(fields)][:threshold][,key=value...]'.")
    return helper


# Every built-in modality has a helper: those above, and one made here for
# each other entry of the built-in list (ced/modalities/builtin.hpp).
for _name, _help in _ced._builtin_modalities():
    if _name not in globals():
        globals()[_name] = _builtin_helper(_name, _help)
        __all__.append(_name)


def _is_open3d(obj):
    return type(obj).__module__.startswith("open3d") and hasattr(obj, "points") and hasattr(obj, "has_colors")


def _from_open3d(pcd, channels):
    """An Open3D PointCloud as arrays: positions, colours (uint8 when every value is an exact multiple of 1/255,
    as for colours read from 8-bit files: then results equal the CLI's), normals."""
    import numpy as np

    points = np.asarray(pcd.points)
    extra = {}
    # Open3D's has_colors()/has_normals() are False when the counts differ from the points': say so instead.
    for what, values in (("colours", pcd.colors), ("normals", pcd.normals)):
        if len(values) and len(values) != len(points):
            raise ValueError(f"Open3D cloud: {len(values)} {what} for {len(points)} points")
    if pcd.has_colors():
        colors = np.asarray(pcd.colors)
        as8 = np.rint(colors * 255.0)
        if np.array_equal(as8 / 255.0, colors) and as8.min(initial=0) >= 0 and as8.max(initial=0) <= 255:
            colors = as8.astype(np.uint8)
        extra["rgb"] = colors
    if pcd.has_normals():
        extra["nx,ny,nz"] = np.asarray(pcd.normals)
    if channels:
        extra.update(channels)
    return points, extra


def _cloud_args(points, channels):
    if _is_open3d(points):
        return _from_open3d(points, channels)
    return points, channels


_cloud_from_arrays = Cloud.__init__


def _cloud_init(self, points, channels=None):
    """Builds a cloud from an (N, 3) array and a dict of channels, a structured array, a Cloud (copied, channels
    added), or an open3d.geometry.PointCloud (its colours and normals become channels, as for detect)."""
    points, channels = _cloud_args(points, channels)
    _cloud_from_arrays(self, points, channels)


Cloud.__init__ = _cloud_init


def _as_cloud(cloud):
    """A ced.Cloud of anything detect() takes as points (arrays are copied into it)."""
    if isinstance(cloud, Cloud):
        return cloud
    points, channels = _cloud_args(cloud, None)
    return Cloud(points, channels)


def render(path, cloud, keypoints=None, view="iso", width=1280, height=960):
    """Draws the cloud (colours, or grey by depth) and its keypoints as red discs into a PNG file.
    view: 'iso', 'top' or 'front'."""
    _ced.render(path, _as_cloud(cloud), keypoints, view, width, height)


def estimate_normals(cloud, radius, threads=0):
    """Unit normals (N x 3) by PCA of the neighbours within `radius`, unoriented; (0, 0, 0) with fewer than 3
    neighbours. What the normals modality uses when the cloud has no nx, ny, nz. `cloud`: a ced.Cloud, arrays as
    for detect, or an Open3D cloud."""
    return _ced.estimate_normals(_as_cloud(cloud), radius, threads)


def estimate_resolution(cloud):
    """The median nearest-neighbour distance over up to 20000 evenly spread points."""
    return _ced.estimate_resolution(_as_cloud(cloud))


def voxel_downsample(cloud, size):
    """Voxel-grid down-sampling as PCL's VoxelGrid (positions and fields averaged): a new ced.Cloud."""
    return _ced.voxel_downsample(_as_cloud(cloud), size)


class _Preset(list):
    """The modalities of a preset, which remember the preset: detect() given them unchanged runs the preset,
    its refinement and keypoint share included, as it does given the preset's name."""

    def __init__(self, name):
        super().__init__(_ced.preset(name))
        self.preset_name = name


def preset(name):
    """The modalities of a preset: 'ced3d' (xyz:0.2), 'ced6d' (xyz:0.2, rgb:0.1), 'robust3d' (xyz:0.2,scale=2),
    'robust6d' (xyz:0.2,scale=2.25,inner=1, rgb:0.5) or 'corner3d' (corner:0.05, corner:0.05,scale=1.5), as a list. The robust presets
    and corner3d also refine their keypoints
    (preset_refines) and keep at most a share of their candidates (preset_keypoint_share): detect() given
    this list unchanged does both, as it does given the name."""
    return _Preset(name)


def _preset_of(modalities):
    """The preset's name when `modalities` is preset()'s list, unchanged; else `modalities`."""
    if isinstance(modalities, _Preset):
        made = [m.name for m in _ced.preset(modalities.preset_name)]
        if [getattr(m, "name", m) for m in modalities] == made:
            return modalities.preset_name
    return modalities


def detect(points, channels=None, modalities=None, radius=0.05, nms_radius=None, min_neighbors=5, threads=0,
           radius_factor=5.0, refine=None, max_keypoints=0, neighborhood="radius", search="grid",
           keypoint_share=None):
    """Detects keypoints.

    points: an (N, 3) float32/float64 array (any strides), a numpy structured array with X, Y, Z fields (PDAL's
        arrays; every other field becomes a channel), a ced.Cloud, or an open3d.geometry.PointCloud.
    channels: a structured array (every field but X, Y, Z is a channel), or a dict name -> (N,) or (N, k) array of
        any numeric dtype. An (N, 3) 'rgb' (or 'colors') array gives
        red, green, blue; a key 'a,b,c' names each column; another (N, k) array 'x' gives x_0 .. x_{k-1}.
    modalities: spec strings ('xyz:0.2', 'rgb:0.1', 'bands(nir,red):0.1'), ced.Modality objects, or a preset name
        ('ced6d', 'ced3d', 'robust6d', 'robust3d', 'corner3d'). None: ced6d (xyz:0.2, rgb:0.1) when the cloud has colour, else ced3d, as the CLI.
    radius: neighbourhood radius, or 'auto' (radius_factor x the estimated resolution).
    nms_radius: None = radius. threads: 0 = all cores (the result does not depend on it).
    refine: move each keypoint to the point nearest the score-weighted centroid of its NMS neighbourhood (more
        repeatable under noise). None: the preset's (on for 'robust3d', 'robust6d'
        and 'corner3d'), else off.
    max_keypoints: keep at most this many keypoints, the ones with the highest score (the product of their
        saliencies), ties to the smaller index; 0 (default): no limit.
    keypoint_share: keep at most this share (0 to 1) of the candidate points as keypoints, the strongest, ranked
        as max_keypoints ranks them (with both, the smaller limit). None: the preset's (0.01 for 'robust3d', whose
        count would otherwise grow with noise), else 0: no limit.
    neighborhood: 'radius' (default: the ball of `radius`), 'knn:K' (the K nearest points, itself included) or
        'adaptive:K[,scale=a][,min=r0][,max=r1]' (each point's radius a x the distance to its K-th nearest,
        clamped). Under knn/adaptive, xyz is measured per unit of each point's own radius (Result.point_radius).
    search: 'grid' (default) or 'cgal': how fixed-radius neighbours are gathered (CGAL's Kd_tree is the
        reference path; the same keypoints, slower).

    Returns a ced.Result. The GIL is released while detecting; Ctrl-C raises KeyboardInterrupt. Called while a
    ced.python_modality's function runs (from it, or from a thread it waits for), the detection runs on the calling
    thread, single-threaded, whatever `threads` says (the result is the same).
    """
    points, channels = _cloud_args(points, channels)
    if nms_radius is not None:
        nms_radius = float(nms_radius)
    modalities = _preset_of(modalities)  # (the counts are checked by _detect, as by plan_tiles)
    for name, value in (("neighborhood", neighborhood), ("search", search)):
        if not isinstance(value, str):
            raise TypeError(f"{name}: expected a str, got {type(value).__name__}")
    return _detect(points, channels, modalities, radius, float(radius_factor), nms_radius, min_neighbors, threads,
                   refine, max_keypoints, neighborhood, search, keypoint_share)


def write(path, cloud, channels=None, format=None):
    """Writes a cloud (a ced.Cloud, arrays as for detect, or an Open3D cloud) atomically; the format from the
    extension (.ply, .pcd, .las, .csv) unless given."""
    points, channels = _cloud_args(cloud, channels)
    if channels:
        points = Cloud(points, channels)
    _write(path, points, format)


def write_keypoints(path, cloud, result, format=None):
    """Writes the keypoints with all their fields and a saliency_<modality> field each, as `ced detect -o`."""
    import numpy as np

    points, channels = _cloud_args(cloud, None)
    full = Cloud(points, channels) if channels or not isinstance(points, Cloud) else points
    if len(result.candidate) != len(full):
        raise ValueError(f"result: detected on a cloud of {len(result.candidate)} points, not on this one of "
                         f"{len(full)}")
    kp = result.keypoints
    extra, made_by = {}, {}
    for name, values in result.saliency.items():
        column = "saliency_" + "".join(c if c.isalnum() else "_" for c in name).rstrip("_")
        if column in made_by:
            raise ValueError(f"modalities {made_by[column]!r} and {name!r} would both write the column {column!r}")
        made_by[column] = name
        extra[column] = np.ascontiguousarray(values[kp])
    _write(path, Cloud(full.select(kp), extra), format)
