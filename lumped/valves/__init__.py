"""Valve kinds: the kind contract and registry (kind), the disc, reed and ball valves.

Modules are imported by their full path (``lumped.valves.<module>``); the package's public
names are exported by ``lumped`` itself.
"""
