"""walker_gait: depth-camera gait analysis for an instrumented wheeled walker."""

__version__ = "0.1.0"
