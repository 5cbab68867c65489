"""The reed as a structure: exact Euler-Bernoulli, mode-function parameters, modal bases, the reed's structural matrices for the pump, the fidelity registry, plucked-reed identification and the reed's fluid quantities.

Modules are imported by their full path (``lumped.reed.<module>``); the package's public
names are exported by ``lumped`` itself.
"""
