"""How a pump model is integrated: the state layout, the right-hand side, its Jacobian, switching surfaces, the compiled Rodas steppers and scipy's reference stepper.

Modules are imported by their full path (``lumped.solver.<module>``); the package's public
names are exported by ``lumped`` itself.
"""
