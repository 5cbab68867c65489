"""Running a pump: simulate, the revolution runner and stop rules, post-processing, traces and warm starts.

Modules are imported by their full path (``lumped.run.<module>``); the package's public
names are exported by ``lumped`` itself.
"""
