# SPDX-License-Identifier: MIT
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import Cloud, Modality, PointsLike

class Random:
    """The seeded generator of the CLI's evaluation (std::mt19937_64)."""

    def __init__(self, seed: int) -> None: ...
    def next(self) -> int: ...

def random_transform(rng: Random, max_translation: float) -> npt.NDArray[np.float64]:
    """A 4x4 rigid transform: rotation uniform over SO(3), translation uniform in [-t, t]^3."""

def transform(cloud: PointsLike, transform: npt.ArrayLike, sigma: float, rng: Random) -> Cloud:
    """The moved cloud, with Gaussian noise of standard deviation `sigma` on every coordinate."""

def measure(source: PointsLike, source_keypoints: npt.ArrayLike, target: PointsLike,
            target_keypoints: npt.ArrayLike, transform: npt.ArrayLike, epsilon: float) -> Tuple[int, int, int]:
    """(|K_P|, |K_Q|, repeated)."""

def random_keypoints(n: int, count: int, rng: Random) -> npt.NDArray[np.uint32]:
    """`count` distinct indices of [0, n), ascending: the random baseline."""

def repeatability(
    cloud: PointsLike,
    detectors: Union[str, Sequence[Union[str, Sequence[Union[str, Modality]]]]] = ("ced6d", "ced3d", "random"),
    noise: Sequence[float] = (0.0, 0.5),
    trials: int = 5,
    seed: int = 1,
    epsilon: float = 2.0,
    resolution: Optional[float] = None,
    radius: Optional[float] = None,
    min_neighbors: int = 5,
    threads: int = 0,
    max_translation: float = 1.0,
) -> List[Dict[str, Union[str, float, int]]]:
    """Relative repeatability as `ced eval repeatability INPUT`: one row per detector, noise level and trial."""
