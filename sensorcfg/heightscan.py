"""`kind: heightscan`: the height of a frame's origin above the terrain, on a grid or rings of rays.

What it measures: rays start `above` metres over points of the pattern around the frame (a body's frame
or a site) and go down; each reads `origin_z - hit_z`, the height of the frame's origin above the first
terrain point the ray meets within `max_distance`, or `miss`. Terrain is every geom welded to the world
(the floor, heightfields, static boxes and stairs) in `geomgroup` that mj_ray sees (alpha above 0, the
material's where the geom has one); moving bodies, the robot's own among them, are not seen, as Isaac
Lab's ray caster sees only its terrain mesh. The rays are cast at a model of the terrain alone
(`terrain_model`), in one `Batch.ray` call on MuJoCo 4 (mj_ray per ray on MuJoCo 3); the frame's pose is
read from MjData as every other sensor reads it. A batch casts the rays of every due simulation in one
call from the same function, so one simulation and a batch agree to the bit.

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
from .errors import UnsupportedError
from .observables.base import Observable
from .physics import raw_structs
from .selection import select

__all__ = ["HeightScan", "heights", "pattern", "ray_starts", "terrain_model", "visible_rgba"]



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
    matrices `mat` (..., 9); `offsets` (nray, 2). Vectorised over the leading axes, elementwise in a fixed
    order (no matrix products, whose summation order may depend on the shapes): one rule for one or many
    simulations."""
    x, y = offsets[:, 0], offsets[:, 1]
    lead = pos.shape[:-1]
    starts = np.empty(lead + (len(offsets), 3))
    dirs = np.zeros(lead + (len(offsets), 3))
    r = mat[..., None, :]  # (..., 1, 9): row-major R, broadcast over the rays
    p = pos[..., None, :]
    if alignment == "full":
        for i in range(3):
            starts[..., i] = p[..., i] + r[..., 3 * i] * x + r[..., 3 * i + 1] * y + r[..., 3 * i + 2] * above
            dirs[..., i] = -r[..., 3 * i + 2]
        return starts, dirs
    dirs[..., 2] = -1.0
    if alignment == "yaw":
        heading = np.arctan2(r[..., 3], r[..., 0])
        c, s = np.cos(heading), np.sin(heading)
        starts[..., 0] = p[..., 0] + (c * x - s * y)
        starts[..., 1] = p[..., 1] + (s * x + c * y)
    else:
        starts[..., 0] = p[..., 0] + x
        starts[..., 1] = p[..., 1] + y
    starts[..., 2] = p[..., 2] + above
    return starts, dirs


def heights(pos: np.ndarray, starts: np.ndarray, dirs: np.ndarray, dist: np.ndarray, miss: float) -> np.ndarray:
    """`origin_z - hit_z` per ray; `miss` where `dist` is negative (no terrain within reach)."""
    hit_z = starts[..., 2] + dist * dirs[..., 2]
    return np.where(dist >= 0, pos[..., None, 2] - hit_z, miss)


def visible_rgba(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """Geom `geom`'s rgba with the alpha mj_ray decides its visibility by: its material's alpha where it
    has a material (`geom_matid >= 0`), else its own (engine_ray.c's `ray_eliminate`: a geom whose alpha
    is 0 is skipped). The terrain model carries no materials, so this alpha stands for both."""
    rgba = np.array(model.geom_rgba[geom], dtype=float)
    material = int(model.geom_matid[geom])
    if material >= 0:
        rgba[3] = model.mat_rgba[material, 3]
    return rgba


def terrain_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A model of `model`'s terrain alone: its geoms welded to the world, where they are, with their
    shapes, heightfields, meshes, groups and visibility (mj_ray skips a geom whose alpha, its material's
    where it has one, is 0: `visible_rgba`). What moves is gone, so every ray meets terrain first, and
    rays from one simulation or many are cast by one function."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)  # terrain poses do not depend on the state
    spec = mujoco.MjSpec()
    for g in np.flatnonzero(model.body_weldid[model.geom_bodyid] == 0):
        geom = spec.worldbody.add_geom()
        geom.type = mujoco.mjtGeom(int(model.geom_type[g]))
        geom.size, geom.pos, geom.group = model.geom_size[g], data.geom_xpos[g], model.geom_group[g]
        geom.rgba = visible_rgba(model, int(g))
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, data.geom_xmat[g])
        geom.quat = quat
        asset = int(model.geom_dataid[g])
        if geom.type == mujoco.mjtGeom.mjGEOM_SDF and int(model.geom_plugin[g]) >= 0:
            raise UnsupportedError(f"geom {model.geom(int(g)).name or f'#{g}'!r} is an SDF computed by a plugin, "
                                   "which a height scan's terrain cannot copy; make it a mesh, or remove the "
                                   "height scans from this suite")
        if geom.type == mujoco.mjtGeom.mjGEOM_HFIELD:
            rows, cols, adr = model.hfield_nrow[asset], model.hfield_ncol[asset], model.hfield_adr[asset]
            spec.add_hfield(name=f"h{g}", size=model.hfield_size[asset], nrow=rows, ncol=cols,
                            userdata=model.hfield_data[adr:adr + rows * cols])
            geom.hfieldname = f"h{g}"
        elif geom.type in (mujoco.mjtGeom.mjGEOM_MESH, mujoco.mjtGeom.mjGEOM_SDF):  # an SDF of a mesh: mj_ray
            vadr, nv = model.mesh_vertadr[asset], model.mesh_vertnum[asset]  # casts at the mesh, as here
            fadr, nf = model.mesh_faceadr[asset], model.mesh_facenum[asset]
            spec.add_mesh(name=f"m{g}", uservert=model.mesh_vert[vadr:vadr + nv].ravel(),
                          userface=model.mesh_face[fadr:fadr + nf].ravel())
            geom.meshname = f"m{g}"
    return spec.compile()


class _Terrain:
    """Casts rays (any leading shape) at a model's terrain: `Batch.ray` on MuJoCo 4 (one call for every ray
    of every simulation), else mj_ray per ray. Returns distances, -1 beyond `max_distance` or on a miss."""

    def __init__(self, model: mujoco.MjModel, scan: ScanConfig):
        self.model = terrain_model(model)
        self.group = None if scan.geomgroup is None else np.isin(np.arange(6), scan.geomgroup).astype(np.uint8)
        self.max_distance = scan.max_distance
        self.data = mujoco.MjData(self.model)
        mujoco.mj_kinematics(self.model, self.data)
        self.batch = None
        if int(mujoco.__version__.split(".")[0]) >= 4:
            from mujoco import batch

            self.batch = batch.Batch(self.model, 1)

    def cast(self, starts: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        flat_starts, flat_dirs = starts.reshape(1, -1, 3), dirs.reshape(1, -1, 3)
        if self.batch is not None:
            dist = self.batch.ray(flat_starts, flat_dirs, geomgroup=self.group, flg_static=True)[0][0]
        else:
            geomid = np.zeros(1, np.int32)
            dist = np.array([mujoco.mj_ray(self.model, self.data, p, v, self.group, 1, -1, geomid)
                             for p, v in zip(flat_starts[0], flat_dirs[0])])
        return np.where(dist <= self.max_distance, dist, -1.0).reshape(starts.shape[:-1])


class HeightScan(Observable):
    """A height scan from the frame of `element` ('body:name' or 'site:name'); see the module docstring."""

    per_simulation = True  # a BatchEnvironment samples it per simulation (every due one at once: batch_reader)

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

    @property
    def scan(self) -> ScanConfig:
        return self._scan

    @property
    def miss(self) -> float:
        """What a ray that meets no terrain within `max_distance` reads."""
        return self._miss

    def frame(self, model: mujoco.MjModel) -> tuple[int, str, str]:
        """The frame's id and the mjData fields of its position and rotation matrix."""
        sel = select(model, self._element)
        return (sel.ids[0], "xpos", "xmat") if sel.type == "body" else (sel.ids[0], "site_xpos", "site_xmat")

    def _values(self, terrain: _Terrain, pos: np.ndarray, mat: np.ndarray) -> np.ndarray:
        """Heights for frames at `pos` (..., 3), `mat` (..., 9): the one rule both paths call."""
        scan = self._scan
        starts, dirs = ray_starts(pos, mat, self._offsets.reshape(-1, 2), scan.above, scan.alignment)
        dist = terrain.cast(starts, dirs)
        return heights(pos, starts, dirs, dist, self._miss).reshape(pos.shape[:-1] + self.shape)

    def _callable(self, physics: Any) -> Callable[[], np.ndarray]:
        model, data = raw_structs(physics)
        element_id, pos_field, mat_field = self.frame(model)
        pos, mat = getattr(data, pos_field), getattr(data, mat_field)
        terrain = _Terrain(model, self._scan)
        return lambda: self._values(terrain, pos[element_id].copy(), mat[element_id].copy())

    def batch_reader(self, model: mujoco.MjModel, batch: Any) -> Callable[[np.ndarray], np.ndarray]:
        """For a `mujoco.batch.Batch` of `model`: the scans of simulations `ids`, (len(ids), *shape), from the
        frame poses its last call left in its bound fields (as one simulation's MjData holds them), every
        ray of every simulation cast in one call."""
        element_id, pos_field, mat_field = self.frame(model)
        pos = batch.bind(pos_field).reshape(batch.nsim, -1, 3)
        mat = batch.bind(mat_field).reshape(batch.nsim, -1, 9)
        terrain = _Terrain(model, self._scan)
        return lambda ids: self._values(terrain, pos[ids, element_id].copy(), mat[ids, element_id].copy())
