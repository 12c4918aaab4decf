"""Time per camera frame with the scene's default render flags, and with some switched off (`camera.scene`).

Each setting is a `sensorcfg.Camera` on the same physics; frames alternate between the settings so that
both see the same machine load; medians of the repeats. The default model is the bundled robot; a
Menagerie robot with cameras (ALOHA) shows what shadows and reflections cost on a real scene:

    MUJOCO_GL=egl python benchmarks/camera.py --model $MENAGERIE_ROOT/aloha/scene.xml --camera overhead_cam \
        --width 640 --height 480 [--repeats 7] [--off shadow,reflection]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402

import sensorcfg  # noqa: E402
from sensorcfg import assets  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default=str(assets.path("robot.xml")))
    parser.add_argument("--camera", default="overview")
    parser.add_argument("--width", type=int, default=None, help="default: the camera's resolution, else 320")
    parser.add_argument("--height", type=int, default=None)
    parser.add_argument("--off", default="shadow,reflection", help="flags to switch off, comma-separated")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()

    physics = sensorcfg.Physics.from_xml_path(args.model)
    if physics.model.nkey:
        mujoco.mj_resetDataKeyframe(physics.model, physics.data, 0)
    physics.forward()
    off = {flag: False for flag in args.off.split(",") if flag}
    settings = {"default flags": None, f"off: {', '.join(off)}": off}
    frames = {label: sensorcfg.Camera(args.camera, args.height, args.width, scene_option=scene)
              .observation_callable(physics) for label, scene in settings.items()}
    for render in frames.values():  # first frames build the renderer and upload textures
        render()
    times: dict[str, list[float]] = {label: [] for label in frames}
    for _ in range(args.repeats):
        for label, render in frames.items():
            start = time.perf_counter()
            render()
            times[label].append(time.perf_counter() - start)
    print(f"{args.model} camera {args.camera!r}, MuJoCo {mujoco.__version__}, MUJOCO_GL={os.environ['MUJOCO_GL']}, "
          f"medians of {args.repeats} frames")
    for label, values in times.items():
        print(f"  {label:40s} {statistics.median(values) * 1e3:9.1f} ms per frame")


if __name__ == "__main__":
    main()
