"""Simulated missions with exact ground truth, and IMU error injection."""
