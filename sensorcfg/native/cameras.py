"""Cameras a suite adds to its model (`cameras:`), written into the model's MjSpec wherever the suite
compiles it (`Suite._compiled`: validate, spec, run, Environment, BatchEnvironment), so a robot file
without a camera (Menagerie's Panda) gets one without being edited.

A camera is mounted in a body's frame, or a site's (then on the site's body, at the site's compiled pose
composed with the camera's). Its name must be new to the model. The model's offscreen buffer grows to hold
a camera's `resolution` (it never shrinks). An MjModel is taken as it is: it must
already carry the suite's cameras (an MjModel from `Suite.compile` does).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import mujoco
import numpy as np

from ..config.models import MountedCameraConfig
from ..errors import SuiteError, did_you_mean
from ..selection import select
from .compile import _spec

__all__ = ["Found", "carried", "mount"]

Found = list[tuple[tuple[str, ...], str]]  # (path in the suite, message)


def _orientation(camera: MountedCameraConfig) -> np.ndarray:
    """The camera's quaternion in its frame (w, x, y, z): `quat` normalised, or `xyaxes` as MuJoCo reads it
    (x normalised, y made orthogonal to it, z = x cross y)."""
    if camera.quat is not None:
        quat = np.asarray(camera.quat, float)
        return quat / np.linalg.norm(quat)
    if camera.xyaxes is None:
        return np.array([1.0, 0.0, 0.0, 0.0])
    x, y = np.asarray(camera.xyaxes[:3], float), np.asarray(camera.xyaxes[3:], float)
    x = x / np.linalg.norm(x)
    y = y - x * np.dot(x, y)
    y = y / np.linalg.norm(y)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([x, y, np.cross(x, y)]).ravel())
    return quat


def _frame(plain: mujoco.MjModel, type_name: str, index: int, camera: MountedCameraConfig
           ) -> tuple[int, np.ndarray, np.ndarray]:
    """(body id, position, quaternion) of the camera in its body's frame."""
    pos, quat = np.asarray(camera.pos, float), _orientation(camera)
    if type_name == "body":
        return index, pos, quat
    site_pos, site_quat = plain.site_pos[index], plain.site_quat[index]
    moved, turned = np.zeros(3), np.zeros(4)
    mujoco.mju_rotVecQuat(moved, pos, site_quat)
    mujoco.mju_mulQuat(turned, site_quat, quat)
    return int(plain.site_bodyid[index]), site_pos + moved, turned


def _body(spec: mujoco.MjSpec, plain: mujoco.MjModel, body: int) -> Any:
    """The spec's body compiled as `body`: by name (a compiler that fuses static bodies renumbers them), else
    by position (an unnamed body: the spec lists bodies in compiled order when none were fused)."""
    name = plain.body(body).name
    found = spec.worldbody if body == 0 else spec.body(name) if name else None
    return found if found is not None else spec.bodies[body]


def mount(source: Any, cameras: Mapping[str, MountedCameraConfig], rejected: Sequence[str] = ()
          ) -> tuple[mujoco.MjSpec, Found]:
    """`source` (an MJCF path or an MjSpec, copied) as an MjSpec with `cameras` added, and the problems of
    those that could not be. Raises ValueError when MuJoCo cannot read or compile the file itself.

    A camera whose frame is wrong is still added, in the world's frame, and the names in `rejected` (cameras
    whose definition the schema refused) as bare cameras there: a camera with a mistake is still a camera the
    suite defines, so the sensors that read it are judged on their own mistakes and a misspelt name is offered
    it ("did you mean"); the suite does not build while its cameras have problems."""
    spec = _spec(source)
    plain = spec.compile()
    own = [plain.camera(i).name for i in range(plain.ncam)]
    found: Found = []
    for name, camera in cameras.items():
        here = ("cameras", name)
        if name in own:
            found.append((here, f"the model already has a camera named {name!r}; give the suite's camera another "
                                "name, or read the model's own as 'camera:" + name + "' without adding one"))
            continue
        frame = _mount_frame(plain, camera, here, found)
        body, pos, quat = _frame(plain, *frame, camera) if frame else (0, np.asarray(camera.pos, float),
                                                                         _orientation(camera))
        added = _body(spec, plain, body).add_camera(name=name, pos=pos, quat=quat, fovy=camera.fovy)
        if camera.resolution is not None:
            added.resolution = list(camera.resolution)
            width, height = camera.resolution  # the offscreen buffer holds the image the suite asks for
            buffer = spec.visual.global_
            buffer.offwidth, buffer.offheight = max(buffer.offwidth, int(width)), max(buffer.offheight, int(height))
    for name in rejected:
        if name not in own and name not in cameras:
            spec.worldbody.add_camera(name=name)
    return spec, found


def _mount_frame(plain: mujoco.MjModel, camera: MountedCameraConfig, here: tuple[str, ...], found: Found
                 ) -> tuple[str, int] | None:
    """The (type, id) of the one body or site `camera.element` names, or None with its problem in `found`."""
    try:
        selection = select(plain, camera.element)
    except SuiteError as e:
        found += [(here + ("element",), p.message) for p in e.problems]
        return None
    if selection.type not in ("body", "site") or len(selection.ids) != 1:
        found.append((here + ("element",), f"a camera is mounted in one frame, 'body:<name>' or "
                                           f"'site:<name>'; got {camera.element!r}"))
        return None
    return selection.type, selection.ids[0]


def carried(model: mujoco.MjModel, cameras: Mapping[str, MountedCameraConfig]) -> Found:
    """The suite's cameras an MjModel given as it is lacks."""
    own = [model.camera(i).name for i in range(model.ncam)]
    return [(("cameras", name), f"the suite adds camera {name!r} when it compiles its model, and this MjModel "
             f"was compiled without it{did_you_mean(name, own)}: pass the model's file or MjSpec, or the MjModel "
             "Suite.compile returns") for name in cameras if name not in own]
