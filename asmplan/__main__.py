"""``python -m asmplan``: the same as the ``asmplan`` console script."""

from .cli import entry

entry()
