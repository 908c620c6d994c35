"""The product's own simulator: truth trajectories, exact IMU increments, LDV and GNSS."""
