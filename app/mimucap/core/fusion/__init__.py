"""Orientation fusion: gyro propagation, error-state EKF, offline smoother, BROAD metric.

Frames and order: ``q_world_from_sensor``, scalar-first Hamilton quaternions, world = ENU.
"""
