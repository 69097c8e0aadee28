"""A kinematic body model fitted by an unscented Kalman filter (Wang et al.'s features).

- :mod:`~streamseg.kinematics.ukf`: the generic UKF update and pass;
- :mod:`~streamseg.kinematics.model`: limbs, forward kinematics and the offline four-pass fit
  of joint angles and bone lengths;
- :mod:`~streamseg.kinematics.tracker`: the causal tracker for live streams.
"""
