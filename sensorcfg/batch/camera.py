"""Cameras across simulations: rendered one simulation at a time, only when some read can see the frame.

A frame needs the simulation's whole MjData as it was right after its physics step, so a batch with
cameras is persistent (one MjData per simulation: memory grows with nsim) and a control step is split
into one `rollout` per substep at which some camera samples. Each sampled frame costs one `get_data` and
one render of that simulation: a Python loop over the simulations that sample it. Which steps sample is
the schedule's periodic sampling pattern (`plan.schedule.Schedule.needed_mask`), so a frame that no read can
see is never rendered; a camera sampling every step with a buffer of 1 renders once per control step.

Frames wait in a per-simulation ring laid out as the schedule's (`Schedule.slot`, as `FixedChannel`'s),
read with one fancy index for all simulations. Noise runs per simulation too, through a copy of the sensor's
own pipeline keyed as the single simulation keys it (`draws.sensor_key`) and at the level the sensor's
pipeline is set to at each reset (`noise.level.follow`), so simulation i is that simulation's `Environment` to
the bit. Corruptors, aggregators and drawn intervals or delays are rejected.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, cast

import mujoco
import numpy as np

from ..draws import sensor_key
from ..noise.level import follow
from ..physics import Physics
from ..plan.bind import Entry
from ..plan.schedule import Schedule

if TYPE_CHECKING:
    from mujoco.batch import Batch

__all__ = ["BatchCameras"]


class _Camera:
    def __init__(self, sensor: Entry, render: Callable[[], np.ndarray], nsim: int):
        self.sensor = sensor
        self.schedule = cast(Schedule, sensor.schedule)  # (`plan.bind` refuses a drawn one)
        self.render = render
        self.observable = sensor.observable  # one with `batch_reader` samples every due simulation in one call
        self.many: Callable[[np.ndarray], np.ndarray] | None = None  # (`batch_reader`: simulations -> samples)
        self.ring = np.zeros((nsim, self.schedule.capacity, *sensor.shape), sensor.dtype)
        self.noise = [copy.deepcopy(sensor.noise) for _ in range(nsim)] if sensor.noise is not None else None
        self.needed = self.schedule.needed_mask()


def _noisy(camera: _Camera, i: int | np.integer, frame: np.ndarray, step: int) -> np.ndarray:
    """Simulation i's sample after its noise (the sample taken at `step`)."""
    return frame if camera.noise is None else camera.noise[int(i)](np.asarray(frame), step)


class BatchCameras:
    """The camera observables of a batch (`entries`: (position, bound observable) each)."""

    def __init__(self, entries: list[tuple[int, Entry]], model: mujoco.MjModel, nsim: int, substeps: int, pad: bool):
        self.data = mujoco.MjData(model)  # each simulation's MjData is copied here to render it
        physics = Physics(model, self.data)
        self.nsim, self.substeps, self.pad = nsim, substeps, pad
        self.positions = [position for position, _ in entries]
        self.cameras = [_Camera(e, e.observable.observation_callable(physics), nsim) for _, e in entries]
        self.model = model
        self._batch: Batch | None = None

    @property
    def batch(self) -> Batch | None:
        """The persistent mujoco.batch.Batch to render from."""
        return self._batch

    @batch.setter
    def batch(self, batch: Batch | None) -> None:
        self._batch = batch
        for camera in self.cameras:
            reader = getattr(camera.observable, "batch_reader", None)
            camera.many = None if reader is None or batch is None else reader(self.model, batch)

    def _frame(self, i: int | np.integer, camera: _Camera) -> np.ndarray:
        if self._batch is None:
            raise RuntimeError("a batch camera rendered before its environment set its mujoco.batch.Batch")
        self._batch.get_data(int(i), self.data)
        frame: np.ndarray = camera.render()
        return frame

    def render_substeps(self, age: np.ndarray, active: np.ndarray) -> list[int]:
        """The substeps (1..substeps) of this control step after which some camera samples some simulation."""
        out = set()
        for camera in self.cameras:
            period = camera.needed.size
            for k in range(1, self.substeps + 1):
                if k not in out and (camera.needed[(age + k) % period] & active).any():
                    out.add(k)
        return sorted(out)

    def sample(self, k: int, age: np.ndarray, active: np.ndarray) -> None:
        """Render the frames due after substep k (`age`: each simulation's steps since reset before this control
        step)."""
        for camera in self.cameras:
            schedule = camera.schedule
            due = np.flatnonzero(camera.needed[(age + k) % camera.needed.size] & active)
            if camera.many is not None and due.size:  # all due simulations at once (height scans)
                frames = camera.many(due)
                if camera.noise is None:
                    camera.ring[due, schedule.slot((age[due] + k) // schedule.interval)] = frames
                    continue
                for row, i in enumerate(due):
                    step = int(age[i]) + k
                    camera.ring[i, schedule.slot(step // schedule.interval)] = _noisy(camera, i, frames[row], step)
                continue
            for i in due:  # one get_data and one render per simulation: the documented cost
                step = int(age[i]) + k
                camera.ring[i, schedule.slot(step // schedule.interval)] = _noisy(camera, i, self._frame(i, camera),
                                                                                   step)

    def reset_noise(self, i: int, entropy: list[int]) -> None:
        """Simulation i's new episode keys for the noisy sensors, as the Updater keys them, at the noise level
        its sensor's own pipeline is set to (`set_noise_level` sets that one only)."""
        for camera in self.cameras:
            if camera.noise is not None:
                follow(camera.noise[i], camera.sensor.noise)
                camera.noise[i].reset(sensor_key(entropy, camera.sensor.name), camera.schedule.interval)

    def reset(self, ids: np.ndarray) -> None:
        """The reset frames of simulations `ids` (rendered after their physics reset)."""
        for camera in self.cameras:
            for i in ids:
                frame = _noisy(camera, i, self._frame(i, camera), 0)
                camera.ring[i] = frame if self.pad else 0
                camera.ring[i, 0] = frame

    def read(self, age: np.ndarray, out: list[Any]) -> None:
        """Each camera's observation of every simulation into `out` at its position."""
        sims = np.arange(self.nsim)[:, None]
        for position, camera in zip(self.positions, self.cameras):
            schedule = camera.schedule
            start = schedule.window_start(age)
            window = camera.ring[sims, schedule.slot(start[:, None] + np.arange(schedule.buffer))]
            out[position] = window if camera.sensor.has_buffer_dim else window[:, 0]
