"""Fluid models of the valves (placeholder package file of the reed's 3-D flow; the fluid
fidelity registry of the thin film and the disc's axisymmetric flow lives here when merged)."""
