"""Lumped (ODE) models: oil, disc and reed check valves, the piston pump."""
