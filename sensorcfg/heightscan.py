"""`kind: heightscan`: the height of a frame's origin above the terrain, on a grid or rings of rays.

What it measures: rays start `above` metres over points of the pattern around the frame (a body's frame
or a site) and go down; each reads `origin_z - hit_z`, the height of the frame's origin above the first
terrain point the ray meets within `max_distance`, or `miss`. Terrain is every geom welded to the world
(the floor, heightfields, static boxes and stairs) in `geomgroup`; geoms of moving bodies, the robot's own
among them, are seen through (a ray that meets one goes on from just past it), as Isaac Lab's ray caster
sees only its terrain mesh. Static geoms do not depend on the simulation's state, so a scan depends only
on the frame's pose, which is read from MjData as every other sensor reads it.

Alignment: 'yaw' turns the pattern with the frame's heading (rays stay vertical), 'full' follows its whole
orientation (rays along its -z; the value is still a vertical height), 'world' keeps world axes.

Shapes: a grid of size [x, y] at `resolution` is (nx, ny) with both ends included (1.6 x 1.0 at 0.1 is
17 x 11; [i, j] is at x_i, y_j); rings are (len(radii), count), ray k at angle 2 pi k / count from the x axis.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from dm_env import specs

from .config.models import ScanConfig
from .observables.base import Observable
from .physics import raw_structs
from .selection import select

__all__ = ["HeightScan", "pattern", "ray_starts", "heights"]

_SEE_THROUGH = 1e-6  # a ray that meets a moving geom starts again this far past it (m)


def pattern(scan: ScanConfig) -> np.ndarray:
    """The pattern's (x, y) offsets in the frame, shaped like the observation plus a last axis of 2."""
    if scan.pattern == "grid":
        axes = [np.linspace(-s / 2, s / 2, int(round(s / scan.resolution)) + 1) for s in scan.size]
        x, y = np.meshgrid(axes[0], axes[1], indexing="ij")
        return np.stack([x, y], axis=-1)
    angles = 2 * np.pi * np.arange(scan.count) / scan.count
    radii = np.asarray(scan.radii, float)[:, None]
    return np.stack([radii * np.cos(angles), radii * np.sin(angles)], axis=-1)


def ray_starts(pos: np.ndarray, mat: np.ndarray, offsets: np.ndarray, above: float,
               alignment: str) -> tuple[np.ndarray, np.ndarray]:
    """Ray starts and unit directions, (..., nray, 3) each, for frames at `pos` (..., 3) with rotation
    matrices `mat` (..., 9); `offsets` (nray, 2). Vectorised over the leading axes (one rule for one or
    many simulations)."""
    local = np.concatenate([offsets, np.full((len(offsets), 1), above)], axis=1)  # (nray, 3)
    rot = mat.reshape(mat.shape[:-1] + (3, 3))
    down = np.zeros(pos.shape[:-1] + (1, 3))
    down[..., 2] = -1.0
    if alignment == "full":
        starts = pos[..., None, :] + np.einsum("...ij,rj->...ri", rot, local)
        return starts, np.broadcast_to(-rot[..., None, :, 2], starts.shape)
    if alignment == "yaw":
        heading = np.arctan2(rot[..., 1, 0], rot[..., 0, 0])[..., None]
        c, s = np.cos(heading), np.sin(heading)
        turned = np.stack([c * local[:, 0] - s * local[:, 1], s * local[:, 0] + c * local[:, 1],
                           np.broadcast_to(local[:, 2], c.shape[:-1] + (len(local),))], axis=-1)
        starts = pos[..., None, :] + turned
    else:
        starts = pos[..., None, :] + local
    return starts, np.broadcast_to(down, starts.shape)


def heights(pos: np.ndarray, starts: np.ndarray, dirs: np.ndarray, dist: np.ndarray, miss: float) -> np.ndarray:
    """`origin_z - hit_z` per ray; `miss` where `dist` is negative (no terrain within reach)."""
    hit_z = starts[..., 2] + dist * dirs[..., 2]
    return np.where(dist >= 0, pos[..., None, 2] - hit_z, miss)


class HeightScan(Observable):
    """A height scan from the frame of `element` ('body:name' or 'site:name'); see the module docstring."""

    per_simulation = True  # a BatchEnvironment casts it per simulation, from that simulation's MjData

    def __init__(self, element: str, scan: ScanConfig, update_interval: Any = 1, buffer_size: int | None = None,
                 delay: Any = None, aggregator: Any = None, corruptor: Callable[..., Any] | None = None):
        self._element = element
        self._scan = scan
        self._offsets = pattern(scan)
        self._miss = float(scan.max_distance - scan.above if scan.miss is None else scan.miss)
        super().__init__(update_interval, buffer_size, delay, aggregator, corruptor)

    def __repr__(self) -> str:
        return f"HeightScan({self._element!r}, {self._scan.pattern})"

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(self._offsets.shape[:-1])

    @property
    def array_spec(self) -> specs.Array | None:
        return None if self._corruptor is not None else specs.Array(self.shape, np.float64)

    def _callable(self, physics: Any) -> Callable[[], np.ndarray]:
        model, data = raw_structs(physics)
        sel = select(model, self._element)
        element_id = sel.ids[0]
        pos, mat = (data.xpos, data.xmat) if sel.type == "body" else (data.site_xpos, data.site_xmat)
        static = model.body_weldid[model.geom_bodyid] == 0
        group = None if self._scan.geomgroup is None else np.isin(np.arange(6), self._scan.geomgroup).astype(np.uint8)
        offsets = self._offsets.reshape(-1, 2)
        scan, shape, miss = self._scan, self.shape, self._miss
        geomid = np.zeros(1, np.int32)

        def cast(start: np.ndarray, vec: np.ndarray) -> float:
            travelled = 0.0
            while travelled <= scan.max_distance:
                dist = mujoco.mj_ray(model, data, start, vec, group, 1, -1, geomid)
                if dist < 0:
                    return -1.0
                if static[geomid[0]]:
                    travelled += dist
                    return travelled if travelled <= scan.max_distance else -1.0
                step = dist + _SEE_THROUGH
                start = start + step * vec
                travelled += step
            return -1.0

        def read() -> np.ndarray:
            origin = pos[element_id].copy()
            starts, dirs = ray_starts(origin, mat[element_id], offsets, scan.above, scan.alignment)
            dist = np.array([cast(starts[r], np.ascontiguousarray(dirs[r])) for r in range(len(offsets))])
            return heights(origin, starts, dirs, dist, miss).reshape(shape)

        return read
