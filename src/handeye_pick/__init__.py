"""handeye-pick: camera-guided picks on Universal Robots arms."""

from handeye_pick.cloud import transform_points

__version__ = "0.1.0"

__all__ = ["__version__", "transform_points"]
