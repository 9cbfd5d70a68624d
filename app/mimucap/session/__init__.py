"""Orchestration without Qt: live pipeline, ring buffers, calibration procedures, recording."""
