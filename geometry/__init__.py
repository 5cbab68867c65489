"""Parametric geometry of the valve parts: one description for formulas and meshes."""

from .disc import DiscValveGeometry, load_disc_geometry
from .errors import InputError
from .reed import GROOVE_KINDS, Groove, GrooveShape, Material, Piece, Reed, Section
from .reed_io import PRESETS, THESIS_PRESETS, load_reed, parse_reed, reed_to_toml
from .reed_port import ReedPort, read_port

__all__ = [
    "DiscValveGeometry", "GROOVE_KINDS", "Groove", "GrooveShape", "InputError", "Material", "PRESETS", "Piece", "Reed",
    "ReedPort", "Section", "THESIS_PRESETS", "load_disc_geometry", "load_reed", "parse_reed", "read_port",
    "reed_to_toml",
]
