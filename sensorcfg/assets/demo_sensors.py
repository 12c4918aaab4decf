"""Python sensors used by the bundled demo suite (`demo.yaml`), as examples of `kind: generic`."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..physics import raw_structs

__all__ = ["hand_to_target"]


def hand_to_target(physics: Any) -> np.ndarray:
    """The vector from the hand site to the target site, in world coordinates (metres)."""
    model, data = raw_structs(physics)
    hand = model.site("hand_site").id
    target = model.site("target_site").id
    return data.site_xpos[target] - data.site_xpos[hand]
