"""Measuring instruments: what turns a sensor's reading into a physical quantity.

``instruments.lts``: the laser triangulation sensor reading a valve's position through
air, a PMMA window and oil (Knutson 2016, section 5.3, Appendix B). This layer sits
beside ``lumped`` on ``geometry``: it reads declared, validated inputs and knows nothing
of the pump.
"""

from instruments.lts import LtsSetup, analyse, position_from_voltage, thesis_setup

__all__ = ["LtsSetup", "analyse", "position_from_voltage", "thesis_setup"]
