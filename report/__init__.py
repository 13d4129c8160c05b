"""Reports: offscreen rendering, plots and HTML built from plan and simulation results."""
