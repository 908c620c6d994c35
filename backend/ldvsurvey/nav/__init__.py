"""Numerical core: Earth model, attitude, mechanization, Kalman filter and smoother, simulator.

Frames: n = local East-North-Up, b = Right-Forward-Up, s = IMU sensor frame.
Knows numpy, scipy and numba only: no files, HTTP, SQL or jobs.
"""
