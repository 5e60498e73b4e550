"""DVL and depth factors for GTSAM (installed as graphnav.factors).

See :mod:`graphnav.factors.dvl` for the measurement model and the Jacobian conventions.
"""
from .depth import depth_factor
from .dvl import (beam_factor, beam_factor_lever_arm, beam_noise, body_velocity_factor,
                  predict_beams)
from .motion import body_velocity_change_factor, nonholonomic_factor

__all__ = ["beam_factor", "beam_factor_lever_arm", "beam_noise", "body_velocity_factor",
           "body_velocity_change_factor", "depth_factor", "nonholonomic_factor", "predict_beams"]
