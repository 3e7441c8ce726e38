"""The ``structbench`` command line: one module per sub-command, each a thin
layer over :mod:`structbench.api`, which is all it imports of structbench."""
from .main import main

__all__ = ["main"]
