"""Height scans on the Warp engine: each world's rays cast by MuJoCo Warp's batched ray caster (`mjw.rays`).

What a scan measures is `sensorcfg.heightscan`'s (the rule's one home: the pattern, the alignments, what a
miss reads, which geoms a ray sees); this module runs it over `nworld` worlds on the device:

- In the suite plan a height scan is a fixed-schedule sensor like any feature (`plan`): its source is its
  own heights, the (nworld, rays) float32 array `heights[scan_field(name)]`, so history rows, delays,
  buffers, noise and reads treat it as they treat an mjData field.
- After each physics step (`cast`), when some world's schedule takes a sample of the scan at its step (the
  plan's `taken` mask; a conditional node, `wp.capture_if`, so the launches stay the same every step and a
  control step is still one CUDA graph), every world's rays start from the frame's pose in MuJoCo Warp's
  `Data` (float32 `xpos`/`xmat` of a body, `site_xpos`/`site_xmat` of a site) as `heightscan.ray_starts`
  places them, in the same order of operations, and are cast in one `mjw.rays` call of nworld x rays rays
  at one MuJoCo Warp model of `heightscan.terrain_model`: the terrain alone, as the CPU engines cast (what
  moves is not seen), the scan's geomgroup, static geoms seen. At a reset every world's rays are cast.
- Each ray reads `origin_z - hit_z` (`heightscan.heights`), or the scan's `miss` beyond `max_distance` or
  where nothing is met.

MuJoCo Warp casts in float32 from float32 poses, so heights agree with the CPU engines' to float32 rounding;
which rays hit agrees exactly except for rays that graze an edge. Geom types its caster does not cast are
refused where the scan would see them (`support.terrain_refusals`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import mujoco
import mujoco_warp as mjw
import numpy as np
import warp as wp
from mujoco_warp._src.types import vec6  # the type of `mjw.rays`' geomgroup

from ..heightscan import HeightScan, pattern, terrain_model
from ..physics import raw_structs
from ..plan.bind import Bound, Entry
from ..plan.compile import compile_plan
from ..plan.records import FixedTiming, SensorRecord, Source, SuitePlan
from .philox import MODULE_OPTIONS

__all__ = ["Scans", "plan", "scan_field"]

wp.set_module_options(MODULE_OPTIONS)  # numpy's roundings (no fused multiply-adds) in the rays' starts

ALIGNMENTS = {"yaw": 0, "full": 1, "world": 2}  # `ScanConfig.alignment` -> the code `_starts` reads
_ALL_GROUPS = vec6(-1.0, -1.0, -1.0, -1.0, -1.0, -1.0)  # mjw.rays: every geom group


def scan_field(name: str) -> str:
    """The plan's source field of height scan `name`: its heights (no mjData field has a colon)."""
    return f"heightscan:{name}"


def plan(bound: Bound, physics: object, nsim: int, substeps: int, pad: bool,
         values: Mapping[str, int] | None = None) -> tuple[Bound, SuitePlan]:
    """`bound` with its height scans moved from the per-simulation sensors to the fixed-schedule ones (after
    the features), and the suite plan of that: each scan reading its own heights (`scan_field`). `values`:
    the size per world of each other source of values of their own that `bound`'s features read (batched
    generic sensors', `warp.generic`)."""
    scans = [e for e in bound.cameras if isinstance(e.observable, HeightScan)]
    others = [e for e in bound.cameras if not isinstance(e.observable, HeightScan)]
    sources = bound.sources()
    nfixed = len(bound.fixed)
    own = [Source(scan_field(e.name), np.arange(math.prod(e.shape))) for e in scans]
    sources = [*sources[:nfixed], *own, *sources[nfixed:]]
    model, data = raw_structs(physics)
    heights = {source.field: (source.positions.size,) for source in own} | {f: (n,) for f, n in (values or {}).items()}
    fields: dict[str, tuple[int, ...]] = {}  # each field read, in order of first use, with its shape
    for source in sources:
        fields.setdefault(source.field, heights[source.field] if source.field in heights
                          else tuple(getattr(data, source.field).shape))
    fixed: list[Entry] = [*bound.fixed, *scans]
    suite_plan = compile_plan(fixed, bound.drawn, sources, fields, nsim, substeps, float(model.opt.timestep), pad)
    return bound._replace(cameras=others, fixed=fixed), suite_plan


@wp.struct
class _ScanPattern:
    """A height scan's rays as its kernels read them (`ScanConfig`): its frame's index among the bodies or sites
    (`HeightScan.frame`), each ray's xy `offsets` in the pattern (`heightscan.pattern`), the height `above` the
    frame its rays start, its `alignment` (`ALIGNMENTS`), and what a ray reads: `miss` beyond `max_distance`."""

    frame: wp.int32
    offsets: wp.array2d[wp.float64]
    above: wp.float64
    alignment: wp.int32
    max_distance: wp.float64
    miss: wp.float64


@wp.struct
class _ScanRays:
    """Every world's rays of a scan as `mjw.rays` casts them, ray i of world w at column w * rays + i: their
    starts `pnt` and directions `vec`, the bodies `exclude`d (in), the distance `dist` to what each meets (-1:
    nothing), its geom `geomid` and `normal` (out)."""

    pnt: wp.array2d[wp.vec3]
    vec: wp.array2d[wp.vec3]
    exclude: wp.array[wp.int32]
    dist: wp.array2d[wp.float32]
    geomid: wp.array2d[wp.int32]
    normal: wp.array2d[wp.vec3]


@wp.kernel
def _due(
    # In:
    steps: wp.array[wp.int64], taken: wp.array[wp.int32],
    # Out:
    due: wp.array[wp.int32],
):
    """due[0] = 1 where some world's schedule takes a sample at its step (`FixedTiming.taken`)."""
    w = wp.tid()
    if taken[wp.int32(steps[w] % wp.int64(taken.shape[0]))] == 1:
        due[0] = 1


@wp.kernel
def _starts(
    # In: the frames' poses (`xpos`/`xmat` or `site_xpos`/`site_xmat`)
    pos: wp.array2d[wp.float32], mat: wp.array2d[wp.float32], pattern: _ScanPattern,
    # Out: the rays' `pnt` and `vec`
    rays: _ScanRays,
):
    """Ray i of world w: its start and direction, as `heightscan.ray_starts` computes them (in float64 from
    the float32 pose, in its order of operations), at column w * rays + i."""
    w, i = wp.tid()
    x = pattern.offsets[i, 0]
    y = pattern.offsets[i, 1]
    above = pattern.above
    alignment = pattern.alignment
    p = 3 * pattern.frame
    r = 9 * pattern.frame
    px = wp.float64(pos[w, p])
    py = wp.float64(pos[w, p + 1])
    pz = wp.float64(pos[w, p + 2])
    sx = px
    sy = py
    sz = pz + above
    d = wp.vec3(0.0, 0.0, -1.0)
    if alignment == 1:  # full: the pattern in the frame's xy plane, rays along its -z
        sx = px + wp.float64(mat[w, r]) * x + wp.float64(mat[w, r + 1]) * y + wp.float64(mat[w, r + 2]) * above
        sy = py + wp.float64(mat[w, r + 3]) * x + wp.float64(mat[w, r + 4]) * y + wp.float64(mat[w, r + 5]) * above
        sz = pz + wp.float64(mat[w, r + 6]) * x + wp.float64(mat[w, r + 7]) * y + wp.float64(mat[w, r + 8]) * above
        d = wp.vec3(-mat[w, r + 2], -mat[w, r + 5], -mat[w, r + 8])
    elif alignment == 0:  # yaw: turned with the frame's heading
        heading = wp.atan2(wp.float64(mat[w, r + 3]), wp.float64(mat[w, r]))
        c = wp.cos(heading)
        s = wp.sin(heading)
        sx = px + (c * x - s * y)
        sy = py + (s * x + c * y)
    else:  # world axes
        sx = px + x
        sy = py + y
    k = w * pattern.offsets.shape[0] + i
    rays.pnt[0, k] = wp.vec3(wp.float32(sx), wp.float32(sy), wp.float32(sz))
    rays.vec[0, k] = d


@wp.kernel
def _heights(
    # In: the frames' positions, and the rays cast
    pos: wp.array2d[wp.float32], pattern: _ScanPattern, rays: _ScanRays,
    # Out:
    heights: wp.array2d[wp.float32],
):
    """`origin_z - hit_z` per ray (`heightscan.heights`); `miss` where no terrain is met within reach."""
    w, i = wp.tid()
    k = w * heights.shape[1] + i
    d = wp.float64(rays.dist[0, k])
    value = pattern.miss
    if d >= wp.float64(0.0) and d <= pattern.max_distance:
        hit_z = wp.float64(rays.pnt[0, k][2]) + d * wp.float64(rays.vec[0, k][2])
        value = wp.float64(pos[w, 3 * pattern.frame + 2]) - hit_z
    heights[w, i] = wp.float32(value)


class _Scan:
    """One height scan's constants and buffers over `nworld` worlds (allocated once)."""

    def __init__(self, model: mujoco.MjModel, record: SensorRecord, observable: HeightScan, nworld: int):
        scan = observable.scan
        frame, self.pos_field, self.mat_field = observable.frame(model)
        offsets = pattern(scan).reshape(-1, 2)
        nray = offsets.shape[0]
        assert isinstance(record.timing, FixedTiming) and nray == math.prod(record.shape)
        self.field = record.source.field
        self.pattern = rule = _ScanPattern()
        rule.frame, rule.offsets = frame, wp.array(offsets, dtype=wp.float64)
        rule.above, rule.alignment = float(scan.above), ALIGNMENTS[scan.alignment]
        rule.max_distance, rule.miss = float(scan.max_distance), float(observable.miss)
        self.geomgroup = _ALL_GROUPS if scan.geomgroup is None else \
            vec6(*(float(g in scan.geomgroup) for g in range(6)))
        self.taken = wp.array(record.timing.taken.astype(np.int32), dtype=wp.int32)
        self.rays = buffers = _ScanRays()
        buffers.pnt = wp.zeros((1, nworld * nray), dtype=wp.vec3)
        buffers.vec = wp.zeros((1, nworld * nray), dtype=wp.vec3)
        buffers.exclude = wp.full(nworld * nray, -1, dtype=wp.int32)  # no body excluded (only terrain is there)
        buffers.dist = wp.full((1, nworld * nray), -1.0, dtype=wp.float32)  # (no terrain: every ray misses)
        buffers.geomid = wp.zeros((1, nworld * nray), dtype=wp.int32)
        buffers.normal = wp.zeros((1, nworld * nray), dtype=wp.vec3)
        self.heights = wp.zeros((nworld, nray), dtype=wp.float32)
        self.due = wp.zeros(1, dtype=wp.int32)


class Scans:
    """The height scans of `plan` (built by `plan`, from `bound`'s entries) over its `nsim` worlds on `device`,
    cast at a MuJoCo Warp model of `model`'s terrain. `heights`: each scan's plan field -> (nworld, rays)
    float32; `pose_fields`: the mjData fields their frames' poses are read from."""

    def __init__(self, model: mujoco.MjModel, plan: SuitePlan, bound: Bound, device: wp.Device):
        observables = {e.name: e.observable for e in bound.fixed if isinstance(e.observable, HeightScan)}
        self.device, self.nworld = device, plan.nsim
        with wp.ScopedDevice(device):
            self._scans = [_Scan(model, record, observables[record.name], plan.nsim)
                           for record in plan.sensors if record.name in observables]
            self._model: mjw.Model | None = None
            if self._scans:
                terrain = terrain_model(model)
                if terrain.ngeom:  # else every ray misses (`dist` stays -1)
                    data = mujoco.MjData(terrain)
                    mujoco.mj_kinematics(terrain, data)  # terrain poses do not depend on the state
                    self._model, self._data = mjw.put_model(terrain), mjw.put_data(terrain, data)
        self.heights = {scan.field: scan.heights for scan in self._scans}
        self.pose_fields = sorted({f for scan in self._scans for f in (scan.pos_field, scan.mat_field)})

    def cast(self, fields: Mapping[str, wp.array], steps: wp.array, every: bool = False) -> None:
        """After a physics step, each scan some world's schedule takes a sample of at its step `steps`; with
        `every` (at a reset: the restarting worlds' reset samples), every scan. `fields`: the pose fields as
        (nworld, values) float32 views."""
        for scan in self._scans:
            if every:
                self._cast(scan, fields)
                continue
            scan.due.zero_()
            wp.launch(_due, dim=self.nworld, inputs=[steps, scan.taken], outputs=[scan.due],
                      device=self.device)
            wp.capture_if(scan.due, on_true=self._cast, scan=scan, fields=fields)

    def _cast(self, scan: _Scan, fields: Mapping[str, wp.array]) -> None:
        n, nray = self.nworld, scan.heights.shape[1]
        pos, mat = fields[scan.pos_field], fields[scan.mat_field]
        with wp.ScopedDevice(self.device):
            rays = scan.rays
            wp.launch(_starts, dim=(n, nray), inputs=[pos, mat, scan.pattern], outputs=[rays])
            if self._model is not None:
                mjw.rays(self._model, self._data, rays.pnt, rays.vec, scan.geomgroup, True, rays.exclude, rays.dist,
                         rays.geomid, rays.normal)
            wp.launch(_heights, dim=(n, nray), inputs=[pos, scan.pattern, rays], outputs=[scan.heights])

