"""Sensor calibration from recorded data: IMU axes, DVL lever arm and mounting, time offsets, noise densities."""
