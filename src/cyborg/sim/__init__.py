"""Simulation layer: a simulated robot base, its maps and route planning, and scenario runs."""
