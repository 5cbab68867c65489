"""What a pump model is: the pump and circuit, the PumpModel, effects and their library, model files, input uncertainties.

Modules are imported by their full path (``lumped.model.pump_model.<module>``); the package's public
names are exported by ``lumped`` itself.
"""
