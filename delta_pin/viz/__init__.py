"""Visualisation of runs: headless meshcat export to one standalone HTML file (and live viewing)."""
