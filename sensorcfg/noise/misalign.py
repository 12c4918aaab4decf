"""The `misalign` stage: a sensor's axes are not the body's. Numpy only.

Each 3-vector of the observation (its last axis) is mapped by a matrix: a fixed cross-axis matrix `M`
(scale factors on the diagonal, cross-coupling off it), turned by a small rotation `R` drawn per episode
(a rotation vector with independent N(0, std^2) components, in radians): the sensor reports R M x. With
neither, nothing changes. `turn` is the one arithmetic: one simulation and a batch call it; `rotation_draw`
the rotation vector's draw, `matrix` the episode's R M from it (the suite plan's engines call them too).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import stages as rt
from .streams import ResetDraw, draw_episode

__all__ = ["Misalign", "matrix", "rotation", "rotation_draw", "turn"]


def rotation(vector: np.ndarray) -> np.ndarray:
    """The rotation matrix of a rotation vector (axis times angle, radians): Rodrigues' formula."""
    angle = float(np.linalg.norm(vector))
    if angle == 0.0:
        return np.eye(3)
    k = np.asarray(vector, float) / angle
    skew = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * skew + (1 - np.cos(angle)) * skew @ skew


def rotation_draw(stream: int, std: float | None) -> ResetDraw | None:
    """The rotation vector drawn at each reset: 3 components std z (None without `std`: no rotation)."""
    return None if std is None else ResetDraw(stream, 1, True, np.full(3, float(std)), None)


def matrix(fixed: np.ndarray, vector: np.ndarray | None) -> np.ndarray:
    """The episode's matrix R M: the rotation of `vector` (None: none) times the fixed matrix M."""
    return np.array(fixed, np.float64) if vector is None else rotation(vector) @ fixed


def turn(src: np.ndarray, matrix: np.ndarray, dst: np.ndarray) -> None:
    """dst[..., i] = sum_j matrix[..., i, j] src[..., j], summed in the order j = 0, 1, 2 whatever the leading
    axes (`matrix` (3, 3), or one per simulation (m, 1, ..., 3, 3) against src (m, ..., 3)); src may be dst."""
    x, y, z = src[..., 0].copy(), src[..., 1].copy(), src[..., 2].copy()
    for i in range(3):
        row = matrix[..., i, :]
        np.multiply(x, row[..., 0], out=dst[..., i])
        dst[..., i] += y * row[..., 1]
        dst[..., i] += z * row[..., 2]


class Misalign(rt.Stage):
    """R M x on the last axis; R drawn at each reset when `std` is given."""

    stateful = False
    stream = 0  # its part of the sensor's streams, where the pipeline keys them by stage

    def __init__(self, ctx: rt.Context, matrix: Any, std: float | None):
        self.ctx = ctx
        self.fixed = np.eye(3) if matrix is None else np.asarray(matrix, np.float64)
        self.std = std
        self.needs_rng = std is not None
        self.matrix = self.fixed.copy()

    def reset(self, streams: rt.Streams | None, stride: int) -> None:
        """The sensor's counter-based streams: the rotation drawn from this stage's part (`rotation_draw`)."""
        draw = rotation_draw(self.stream, self.std)
        self.matrix = matrix(self.fixed, None if draw is None or streams is None else draw_episode(draw, streams))

    def __call__(self, src: np.ndarray, dst: np.ndarray, step: int) -> None:
        turn(src, self.matrix, dst)
