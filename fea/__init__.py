"""Finite-element references (scikit-fem): beam, plate and solid reeds; seat and stop."""
