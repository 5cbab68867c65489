"""Oil properties and the flow laws through a valve (orifice flow with Cd(Re)): plain float functions numba compiles.

Modules are imported by their full path (``lumped.fluid.<module>``); the package's public
names are exported by ``lumped`` itself.
"""
