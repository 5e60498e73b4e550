"""DVL and depth factors for GTSAM (installed as graphnav.factors).

See :mod:`graphnav.factors.dvl` for the measurement model and the Jacobian conventions.
"""
from .depth import depth_factor
from .dvl import (N_DVL_ERRORS, beam_factor, beam_factor_dvl_errors, beam_factor_lever_arm, beam_noise,
                  body_velocity_factor, predict_beams)

__all__ = ["N_DVL_ERRORS", "beam_factor", "beam_factor_dvl_errors", "beam_factor_lever_arm", "beam_noise", "body_velocity_factor",
           "depth_factor", "predict_beams"]
