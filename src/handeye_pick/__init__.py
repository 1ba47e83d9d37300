"""handeye-pick: camera-guided picks on Universal Robots arms."""

__version__ = "0.1.0"
