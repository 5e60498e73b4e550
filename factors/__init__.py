"""DVL, depth, heading and position-fix factors for GTSAM (installed as graphnav.factors).

See :mod:`graphnav.factors.dvl` for the measurement model and the Jacobian conventions.
"""
from .aiding import heading_factor, horizontal_position_factor
from .depth import depth_factor
from .dvl import (
                  N_DVL_ERRORS,
                  beam_difference_factor,
                  beam_factor,
                  beam_factor_dvl_errors,
                  beam_factor_lever_arm,
                  beam_noise,
                  body_velocity_factor,
                  dvl_factor,
                  dvl_velocity_factor,
                  predict_beams,
)
from .motion import body_velocity_change_factor, nonholonomic_factor

__all__ = ["N_DVL_ERRORS", "beam_difference_factor", "beam_factor", "beam_factor_dvl_errors", "beam_factor_lever_arm",
           "beam_noise", "body_velocity_change_factor", "body_velocity_factor", "depth_factor", "dvl_factor", "dvl_velocity_factor",
           "heading_factor", "horizontal_position_factor", "nonholonomic_factor", "predict_beams"]
