"""Figures built from evaluation result files (never imports the simulator)."""

from selfright.plots.heatmaps import make_plots

__all__ = ["make_plots"]
