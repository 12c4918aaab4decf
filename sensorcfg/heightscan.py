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


class _Terrain:
    """What a model's rays may hit, and the distance to a terrain geom from a ray's own start.

    A ray's value never depends on the moving geoms it passed through: once the first terrain geom along
    it is known, its distance is recomputed from the ray's start with that geom's own ray function (the
    one mj_ray calls), so one simulation (mj_ray per ray, on MjData's kinematics) and a batch
    (`Batch.ray`, which recomputes kinematics from the state) agree to the bit.
    """

    def __init__(self, model: mujoco.MjModel, scan: ScanConfig):
        self.model = model
        self.static = np.asarray(model.body_weldid[model.geom_bodyid] == 0)
        self.group = None if scan.geomgroup is None else np.isin(np.arange(6), scan.geomgroup).astype(np.uint8)
        self.max_distance = scan.max_distance
        self.data = mujoco.MjData(model)  # terrain geoms are welded to the world: their poses are constants
        mujoco.mj_kinematics(model, self.data)

    def snap(self, geom: int, start: np.ndarray, vec: np.ndarray) -> float:
        m, d, kind = self.model, self.data, int(self.model.geom_type[geom])
        if kind == int(mujoco.mjtGeom.mjGEOM_HFIELD):
            return float(mujoco.mj_rayHfield(m, d, geom, start, vec))
        if kind == int(mujoco.mjtGeom.mjGEOM_MESH):
            return float(mujoco.mj_rayMesh(m, d, geom, start, vec))
        return float(mujoco.mju_rayGeom(d.geom_xpos[geom], d.geom_xmat[geom], m.geom_size[geom], start, vec, kind))

    def resolve(self, starts: np.ndarray, dirs: np.ndarray, cast: Cast) -> np.ndarray:
        """Distances (..., nray) to the first terrain geom within reach, -1 for none; `cast(starts, dirs,
        mask)` returns (dist, geomid) of the first geom for the rays in `mask` (others may be anything)."""
        dist, geom = cast(starts, dirs, np.ones(starts.shape[:-1], bool))
        out = np.where(geom >= 0, dist, -1.0)
        moving = (geom >= 0) & ~self.static[np.maximum(geom, 0)]
        here, travelled = starts.copy(), np.zeros(dist.shape)
        while moving.any():
            step = np.where(moving, dist + _SEE_THROUGH, 0.0)
            here = here + step[..., None] * dirs
            travelled += step
            moving &= travelled <= self.max_distance
            dist, geom = cast(here, dirs, moving)
            landed = moving & (geom >= 0) & self.static[np.maximum(geom, 0)]
            for i in zip(*np.nonzero(landed)):
                out[i] = self.snap(int(geom[i]), starts[i], np.ascontiguousarray(dirs[i]))
            out[moving & (geom < 0)] = -1.0
            out[moving & (travelled > self.max_distance)] = -1.0
            moving &= (geom >= 0) & ~landed
        return np.where(out <= self.max_distance, out, -1.0)


Cast = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


class HeightScan(Observable):
    """A height scan from the frame of `element` ('body:name' or 'site:name'); see the module docstring."""

    per_simulation = True  # a BatchEnvironment samples it per simulation (all due ones at once: batch_reader)

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

    def _frame(self, model: mujoco.MjModel) -> tuple[int, str, str]:
        sel = select(model, self._element)
        return (sel.ids[0], "xpos", "xmat") if sel.type == "body" else (sel.ids[0], "site_xpos", "site_xmat")

    def _values(self, terrain: _Terrain, pos: np.ndarray, mat: np.ndarray, cast: Cast) -> np.ndarray:
        """Heights for frames at `pos` (..., 3), `mat` (..., 9): the one rule both paths call."""
        scan = self._scan
        starts, dirs = ray_starts(pos, mat, self._offsets.reshape(-1, 2), scan.above, scan.alignment)
        dirs = np.ascontiguousarray(dirs)
        dist = terrain.resolve(starts, dirs, cast)
        return heights(pos, starts, dirs, dist, self._miss).reshape(pos.shape[:-1] + self.shape)

    def _callable(self, physics: Any) -> Callable[[], np.ndarray]:
        model, data = raw_structs(physics)
        element_id, pos_field, mat_field = self._frame(model)
        pos, mat = getattr(data, pos_field), getattr(data, mat_field)
        terrain = _Terrain(model, self._scan)
        geomid = np.zeros(1, np.int32)

        def cast(starts: np.ndarray, dirs: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            dist, geom = np.full(mask.shape, -1.0), np.full(mask.shape, -1, np.int32)
            for i in zip(*np.nonzero(mask)):
                dist[i] = mujoco.mj_ray(model, data, starts[i], dirs[i], terrain.group, 1, -1, geomid)
                geom[i] = geomid[0]
            return dist, geom

        return lambda: self._values(terrain, pos[element_id].copy(), mat[element_id].copy(), cast)

    def batch_reader(self, model: mujoco.MjModel, batch: Any) -> Callable[[np.ndarray], np.ndarray]:
        """For a `mujoco.batch.Batch` of `model`: the scans of simulations `ids`, (len(ids), *shape), from the
        frame poses the last rollout left in its bound fields, cast with `Batch.ray` for all of them at once."""
        element_id, pos_field, mat_field = self._frame(model)
        nsim = batch.nsim
        pos = batch.bind(pos_field).reshape(nsim, -1, 3)
        mat = batch.bind(mat_field).reshape(nsim, -1, 9)
        terrain = _Terrain(model, self._scan)

        def read(ids: np.ndarray) -> np.ndarray:
            def cast(starts: np.ndarray, dirs: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                dist, geom = batch.ray(starts, dirs, geomgroup=terrain.group, flg_static=True, bodyexclude=-1,
                                       ids=ids)
                return dist, geom

            return self._values(terrain, pos[ids, element_id].copy(), mat[ids, element_id].copy(), cast)

        return read
