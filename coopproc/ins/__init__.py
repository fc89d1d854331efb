"""Strapdown INS core (issue 12): earth model, mechanization, coarse alignment and the
error-state EKF with its measurement updates, as a library (docs/methods-ins.md).

Frames: body x forward, y left, z up (ROS REP 103); navigation frame the local-level
ENU frame at the INS position; position as geodetic latitude, longitude (rad) and
ellipsoidal height (m, WGS-84).
"""
