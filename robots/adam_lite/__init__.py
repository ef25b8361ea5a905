"""PNDbotics Adam Lite: description (adam_lite.urdf, made by description.py), robot config (config.py) and what the
locomotion task reads of it (loco.py, registered in robots.ROBOTS)."""

from robots.adam_lite.config import ADAM_LITE

__all__ = ["ADAM_LITE"]
