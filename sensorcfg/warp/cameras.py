"""Camera sensors over `nworld` worlds, rendered by MuJoCo Warp's batch ray tracer (`mujoco_warp.render`).

Each camera sensor has its own render context (one camera, its image size and mode, the scene flags
`camera_support.settings` follows) and a ring of frames per world laid out as the CPU batch's
(`batch/camera.py`, `plan/schedule.Schedule`): (nworld, capacity, height * width * channels) in the CPU
camera's dtype (rgb uint8, depth float32 metres, segmentation int32 (object id, object type)); sample k of
a world lives in slot `k % capacity`, and a read shows the slots of its window, as on the CPU.

Which frames are rendered: after substep k of a control step (1-based), every world is rendered when the
sensor's schedule can take a frame there for some world (the steps `Schedule.needed_mask` marks: frames no
read can see are never stored), and the worlds whose step `steps[w]` takes one store it; at a restart every
world is rendered and the restarted ones store their reset frame (the padding too). The launches are the
same every control step and every buffer is allocated here, so a CUDA graph records them (`mujoco_warp`
captures `refit_bvh` and `render` in graphs itself).

What a frame is (docs/warp.md, "Cameras"): the renderer casts one ray per pixel centre, so depth is the
planar distance (metres along the camera's axis) to the first geom the pixel's centre sees, as OpenGL's
depth after `mujoco.Renderer`'s conversion; a pixel that sees nothing holds the value the CPU camera gives
the far clipping plane (`background_depth`). Segmentation is (geom id, mjOBJ_GEOM), (-1, -1) for nothing.
RGB is the ray tracer's shading (lights, headlight, textures, shadows when on), not OpenGL's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import mujoco
import mujoco_warp as mjw
import numpy as np
import warp as wp

from ..observables.camera import MODES
from .camera_support import settings
from .worlds import Worlds

__all__ = ["CameraEntry", "CameraSchedule", "Cameras", "background_depth", "render_substeps"]


class CameraEntry(NamedTuple):
    """A camera sensor as the suite binds it: its `name`, its `observable`, and its fixed schedule's numbers
    (`plan/schedule.Schedule`'s): a sample every `interval` steps, read `delay` steps late, `buffer` samples
    a read; `capacity` ring slots; `needed`: over its period, the steps whose frame some read can see
    (`Schedule.needed_mask`)."""

    name: str
    observable: Any
    interval: int
    delay: int
    buffer: int
    capacity: int
    needed: np.ndarray


def background_depth(model: mujoco.MjModel, camera: int) -> float:
    """The depth `mujoco.Renderer` gives a pixel that sees nothing (its depth buffer's far value, converted
    as it converts every pixel: float32 clip planes, float64 arithmetic, float32 result)."""
    extent = model.stat.extent
    znear, zfar = np.float32(model.vis.map.znear * extent), np.float32(model.vis.map.zfar * extent)
    if model.cam_projection[camera] == mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC:
        return float(np.float32(np.float64(zfar)))
    c = -(zfar + znear) / (zfar - znear)
    d = -(np.float32(2) * zfar * znear) / (zfar - znear)
    c, d = np.float32(-0.5) * c - np.float32(0.5), np.float32(-0.5) * d
    return float(np.float32(np.float64(d) / (np.float64(0.0) + c)))


def render_substeps(needed: np.ndarray, substeps: int) -> list[int]:
    """The substeps k (1..substeps) of a control step after which some world can need a frame: steps
    `c * substeps + k` (control steps start at multiples of `substeps`) that `needed` (over the schedule's
    period) marks."""
    period = needed.size
    return [k for k in range(1, substeps + 1)
            if any(needed[(c * substeps + k) % period] for c in range(period // math.gcd(period, substeps)))]


@wp.struct
class CameraSchedule:
    """A camera sensor's schedule (`plan/schedule.Schedule`) as its kernels read it: a sample every
    `interval` steps, read `delay` steps late, kept in a ring of `capacity` frames; `needed`: over its period,
    the steps whose frame some read can see (`Schedule.needed_mask`)."""

    needed: wp.array[wp.int32]
    interval: wp.int64
    delay: wp.int64
    capacity: wp.int64


@wp.func
def _slot(sample: wp.int64, capacity: wp.int64) -> wp.int32:
    return wp.int32(((sample % capacity) + capacity) % capacity)


@wp.func
def _floor_div(a: wp.int64, b: wp.int64) -> wp.int64:
    q = a / b
    if a % b != wp.int64(0) and (a < wp.int64(0)) != (b < wp.int64(0)):
        q = q - wp.int64(1)
    return q


@wp.func
def _target(w: wp.int32, steps: wp.array[wp.int64], schedule: CameraSchedule) -> wp.int32:
    """The slot world w's frame at its current step goes to, or -1 when its schedule takes none there."""
    s = steps[w]
    if schedule.needed[wp.int32(s % wp.int64(schedule.needed.shape[0]))] == 0:
        return -1
    return _slot(s / schedule.interval, schedule.capacity)


# The store kernels: world w's frame (pixel p) into its ring at its step (`reset` 0), or at a reset (1) into
# slot 0 and, with `pad` (`pad_with_initial_value`), every other slot (else zeros there).


@wp.kernel
def _store_rgb(
    # In:
    packed: wp.array2d[wp.uint32], steps: wp.array[wp.int64], mask: wp.array[wp.int32], schedule: CameraSchedule,
    reset: wp.int32, pad: wp.int32,
    # Out:
    ring: wp.array3d[wp.uint8],
):
    w, p = wp.tid()
    if mask[w] == 0:
        return
    v = packed[w, p]
    r = wp.uint8((v >> wp.uint32(16)) & wp.uint32(255))
    g = wp.uint8((v >> wp.uint32(8)) & wp.uint32(255))
    b = wp.uint8(v & wp.uint32(255))
    if reset == 0:
        slot = _target(w, steps, schedule)
        if slot >= 0:
            ring[w, slot, 3 * p] = r
            ring[w, slot, 3 * p + 1] = g
            ring[w, slot, 3 * p + 2] = b
        return
    for slot in range(wp.int32(schedule.capacity)):
        keep = slot == 0 or pad == 1
        ring[w, slot, 3 * p] = wp.where(keep, r, wp.uint8(0))
        ring[w, slot, 3 * p + 1] = wp.where(keep, g, wp.uint8(0))
        ring[w, slot, 3 * p + 2] = wp.where(keep, b, wp.uint8(0))


@wp.kernel
def _store_depth(
    # In: the depths, and what a pixel that sees nothing reads (`background_depth`)
    depth: wp.array2d[wp.float32], background: wp.float32, steps: wp.array[wp.int64], mask: wp.array[wp.int32],
    schedule: CameraSchedule, reset: wp.int32, pad: wp.int32,
    # Out:
    ring: wp.array3d[wp.float32],
):
    w, p = wp.tid()
    if mask[w] == 0:
        return
    x = depth[w, p]
    if x <= wp.float32(0.0):  # the ray hit nothing nearer than the far plane
        x = background
    if reset == 0:
        slot = _target(w, steps, schedule)
        if slot >= 0:
            ring[w, slot, p] = x
        return
    for slot in range(wp.int32(schedule.capacity)):
        ring[w, slot, p] = wp.where(slot == 0 or pad == 1, x, wp.float32(0.0))


@wp.kernel
def _store_segmentation(
    # In:
    seg: wp.array2d[wp.vec2i], steps: wp.array[wp.int64], mask: wp.array[wp.int32], schedule: CameraSchedule,
    reset: wp.int32, pad: wp.int32,
    # Out:
    ring: wp.array3d[wp.int32],
):
    w, p = wp.tid()
    if mask[w] == 0:
        return
    v = seg[w, p]
    if reset == 0:
        slot = _target(w, steps, schedule)
        if slot >= 0:
            ring[w, slot, 2 * p] = v[0]
            ring[w, slot, 2 * p + 1] = v[1]
        return
    for slot in range(wp.int32(schedule.capacity)):
        keep = slot == 0 or pad == 1
        ring[w, slot, 2 * p] = wp.where(keep, v[0], wp.int32(0))
        ring[w, slot, 2 * p + 1] = wp.where(keep, v[1], wp.int32(0))


@wp.kernel
def _read(
    # In:
    ring: wp.array3d[Any], steps: wp.array[wp.int64], schedule: CameraSchedule,
    # Out:
    out: wp.array3d[Any],
):
    """out[w, b]: slot b of the window of world w's read at its step (oldest first; padding below 0)."""
    w, b, i = wp.tid()
    newest = _floor_div(steps[w] - schedule.delay, schedule.interval)
    out[w, b, i] = ring[w, _slot(newest - wp.int64(out.shape[1] - 1 - b), schedule.capacity), i]


_WP = {np.dtype(np.uint8): wp.uint8, np.dtype(np.float32): wp.float32, np.dtype(np.int32): wp.int32}


class _Camera:
    """One camera sensor: its render context, schedule tables, ring and read buffer."""

    def __init__(self, entry: CameraEntry, model: mujoco.MjModel, nworld: int, substeps: int,
                 shape: tuple[int, ...]):
        observable, needed = entry.observable, entry.needed
        self.name, self.mode = entry.name, observable.mode
        cam = observable.camera_id(model)
        width, height = observable.width, observable.height
        channels, dtype, _, _ = MODES[self.mode]
        self.substeps = frozenset(render_substeps(needed, substeps))
        self.background = background_depth(model, cam)
        self.rc = mjw.create_render_context(
            model, nworld=nworld, cam_res=[(width, height)], render_rgb=[self.mode == "rgb"],
            render_depth=[self.mode == "depth"], render_seg=[self.mode == "segmentation"],
            cam_active=[i == cam for i in range(model.ncam)],  # (a flag per camera: 3.11's and 4.x's form)
            **settings(observable))
        self.pixels = width * height
        size = self.pixels * channels
        self.schedule = timing = CameraSchedule()
        timing.needed = wp.array(needed.astype(np.int32), dtype=wp.int32)
        timing.interval, timing.delay, timing.capacity = entry.interval, entry.delay, entry.capacity
        self.ring = wp.zeros((nworld, entry.capacity, size), dtype=_WP[np.dtype(dtype)])
        self.out = wp.zeros((nworld, entry.buffer, size), dtype=_WP[np.dtype(dtype)])
        # the CPU camera's (nworld, [buffer,] height, width, channels) as Warp arrays have at most 4 axes:
        # (nworld, [buffer,] height, width) of vectors of the channels, a view of `out`
        self.observation = wp.array(ptr=self.out.ptr, dtype=wp.types.vector(channels, _WP[np.dtype(dtype)]),
                                    shape=(nworld, *shape[:-1]), device=self.out.device, copy=False)


class Cameras:
    """The camera sensors of a suite over `worlds` (`entries`, in the suite's order; `shapes`: each one's read
    shape per world, as the CPU engines give it)."""

    def __init__(self, entries: Sequence[CameraEntry], model: mujoco.MjModel, worlds: Worlds, substeps: int,
                 pad: bool, shapes: Mapping[str, tuple[int, ...]]):
        self.worlds, self.pad = worlds, int(pad)
        n = worlds.nworld
        with wp.ScopedDevice(worlds.device):
            self.cameras = [_Camera(entry, model, n, substeps, shapes[entry.name]) for entry in entries]
            self.everyone = wp.ones(n, dtype=wp.int32)
        self.names = [c.name for c in self.cameras]

    def _render(self, camera: _Camera, mask: wp.array, reset: int) -> None:
        m, d, n = self.worlds.model, self.worlds.data, self.worlds.nworld
        mjw.refit_bvh(m, d, camera.rc)
        mjw.render(m, d, camera.rc)
        steps, rc, schedule = self.worlds.steps, camera.rc, camera.schedule
        if camera.mode == "rgb":
            wp.launch(_store_rgb, dim=(n, camera.pixels), inputs=[rc.rgb_data, steps, mask, schedule, reset, self.pad],
                      outputs=[camera.ring])
        elif camera.mode == "depth":
            wp.launch(_store_depth, dim=(n, camera.pixels),
                      inputs=[rc.depth_data, camera.background, steps, mask, schedule, reset, self.pad],
                      outputs=[camera.ring])
        else:
            wp.launch(_store_segmentation, dim=(n, camera.pixels),
                      inputs=[rc.seg_data, steps, mask, schedule, reset, self.pad], outputs=[camera.ring])

    def record(self, substep: int) -> None:
        """After substep `substep` (1-based) of a control step: the frames the worlds' schedules take."""
        with wp.ScopedDevice(self.worlds.device):
            for camera in self.cameras:
                if substep in camera.substeps:
                    self._render(camera, self.everyone, 0)

    def reset(self, mask: wp.array) -> None:
        """The reset frames of the masked worlds ((nworld,) int32; their physics restarted and forwarded)."""
        with wp.ScopedDevice(self.worlds.device):
            for camera in self.cameras:
                self._render(camera, mask, 1)

    def read(self) -> dict[str, wp.array]:
        """Every camera's read at each world's step, as (nworld, *shape) device arrays."""
        steps, out = self.worlds.steps, {}
        with wp.ScopedDevice(self.worlds.device):
            for camera in self.cameras:
                wp.launch(_read, dim=camera.out.shape, inputs=[camera.ring, steps, camera.schedule],
                          outputs=[camera.out])
                out[camera.name] = camera.observation
        return out
