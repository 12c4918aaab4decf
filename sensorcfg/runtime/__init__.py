"""Scheduling, delaying, buffering and aggregating samples: numpy only, no mujoco."""
