"""selfright: benchmark and training framework for legged-robot self-righting."""

__version__ = "0.1.0"
