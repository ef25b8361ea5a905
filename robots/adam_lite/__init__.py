"""PNDbotics Adam Lite: description (adam_lite.urdf, made by description.py) and robot config."""

from robots.adam_lite.config import ADAM_LITE

__all__ = ["ADAM_LITE"]
