"""graphnav: factor-graph INS/DVL navigation for AUVs."""
__version__ = "0.1.0"
