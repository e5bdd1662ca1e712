"""Plots and HTML reports: the only place that imports matplotlib."""
