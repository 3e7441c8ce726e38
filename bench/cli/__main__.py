"""``python -m structbench.cli``."""
import sys

from .main import main

sys.exit(main())
