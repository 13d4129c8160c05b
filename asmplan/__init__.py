"""asmplan: plan robot assembly from a product YAML and prove every step in simulation.

The public API is re-exported lazily (see ``__getattr__``) so that importing a subpackage
does not import the whole tool.
"""

__version__ = "0.1.0"
