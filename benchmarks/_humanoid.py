"""The benchmark setting shared by benchmarks/updater.py and benchmarks/batch.py.

dm_control's `suite/humanoid.xml` (read from the installed dm_control, or from its wheel when dm_control
cannot be imported, e.g. next to MuJoCo 4), and a 20-observable proprioceptive suite with mixed
intervals, delays, buffers and aggregators.
"""

from __future__ import annotations

import glob
import os
import subprocess
import sys
import tempfile
import zipfile

HINGES = ["abdomen_z", "abdomen_y", "abdomen_x", "right_hip_x", "right_hip_z", "right_hip_y", "right_knee",
          "right_ankle_y", "right_ankle_x", "left_hip_x", "left_hip_z", "left_hip_y", "left_knee",
          "left_ankle_y", "left_ankle_x", "right_shoulder1", "right_shoulder2", "right_elbow",
          "left_shoulder1", "left_shoulder2", "left_elbow"]
BODIES = ["torso", "head", "lower_waist", "pelvis", "right_thigh", "right_shin", "right_foot", "left_thigh",
          "left_shin", "left_foot", "right_upper_arm", "right_lower_arm", "right_hand", "left_upper_arm",
          "left_lower_arm", "left_hand"]
TOUCH = ["torso_touch", "head_touch", "lower_waist_touch", "butt_touch", "right_thigh_touch", "right_shin_touch",
         "left_thigh_touch", "left_shin_touch", "right_hand_touch", "left_hand_touch"]

# name: (kind, element type, names (a str = one element, a list = batched), interval, delay, buffer, aggregator)
SUITE = {
    "joint_pos": ("qpos", "joint", HINGES, 1, 0, 1, None),
    "joint_vel": ("qvel", "joint", HINGES, 1, 0, 1, None),
    "joint_acc": ("qacc", "joint", HINGES, 2, 1, 2, "mean"),
    "joint_torque": ("qfrc_actuator", "joint", HINGES, 1, 2, 1, None),
    "body_pos": ("xpos", "body", BODIES, 1, 0, 1, None),
    "torso_quat_hist": ("xquat", "body", "torso", 1, 0, 3, None),
    "head_orient": ("xmat", "body", "head", 5, 0, 1, None),
    "torso_com": ("subtree_com", "body", "torso", 1, 1, 1, None),
    "torso_cvel": ("cvel", "body", "torso", 2, 0, 2, "mean"),
    "feet_cfrc": ("cfrc_ext", "body", ["right_foot", "left_foot"], 1, 0, 4, "max"),
    "accel": ("sensordata", "sensor", "torso_accel", 1, 2, 4, "mean"),
    "gyro": ("sensordata", "sensor", "torso_gyro", 1, 2, 4, "mean"),
    "velocimeter": ("sensordata", "sensor", "torso_vel", 1, 0, 1, None),
    "touch": ("sensordata", "sensor", TOUCH, 5, 0, 1, None),
    "ankle_force": ("sensordata", "sensor", ["left_ankle_force", "right_ankle_force"], 1, 3, 2, "median"),
    "knee_torque": ("sensordata", "sensor", ["left_knee_torque", "right_knee_torque"], 2, 0, 1, None),
    "extremities": ("xpos", "site", ["right_hand", "left_hand", "right_left_foot", "left_left_foot"], 1, 0, 1, None),
    "head_site": ("xmat", "site", "head", 1, 1, 1, None),
    "geom_pos": ("xpos", "geom", ["torso", "head"], 5, 5, 1, None),
    "actuator_force": ("force", "actuator", HINGES, 1, 0, 5, "min"),
}


def humanoid_xml() -> tuple[str, dict[str, bytes]]:
    """(xml text, assets) of dm_control's suite/humanoid.xml."""
    try:
        from dm_control.suite import humanoid

        return humanoid.get_model_and_assets()
    except Exception:  # dm_control not importable here (e.g. next to MuJoCo 4): read its wheel
        pass
    cache = os.path.join(tempfile.gettempdir(), "sensorcfg-bench-dmcontrol")
    wheels = glob.glob(os.path.join(cache, "dm_control-*.whl"))
    if not wheels:
        subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps", "dm-control==1.0.50",
                        "-d", cache], check=True)
        wheels = glob.glob(os.path.join(cache, "dm_control-*.whl"))
    with zipfile.ZipFile(wheels[0]) as wheel:
        xml = wheel.read("dm_control/suite/humanoid.xml").decode()
        assets = {"./common/" + name.rsplit("/", 1)[-1]: wheel.read(name) for name in wheel.namelist()
                  if name.startswith("dm_control/suite/common/") and name.endswith(".xml")}
    return xml, assets


def sensorcfg_observables(suite: dict = SUITE) -> dict:
    import sensorcfg

    out = {}
    for name, (kind, etype, names, interval, delay, buffer, agg) in suite.items():
        element = f"{etype}:{names}" if isinstance(names, str) else [f"{etype}:{n}" for n in names]
        obs = sensorcfg.Feature(kind, element, update_interval=interval, delay=delay, buffer_size=buffer,
                                aggregator=agg)
        obs.enabled = True
        out[name] = obs
    return out
