"""Points and clouds: the camera-to-base transform and the cloud file formats."""
