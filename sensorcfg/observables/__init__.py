"""Observable types: what one sample is."""

from .aggregators import AGGREGATORS
from .base import Observable
from .camera import Camera
from .feature import Feature
from .generic import Generic

__all__ = ["AGGREGATORS", "Camera", "Feature", "Generic", "Observable"]
