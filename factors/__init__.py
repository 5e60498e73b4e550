"""DVL and IMU factors for GTSAM (installed as graphnav.factors)."""
