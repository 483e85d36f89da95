"""Lets the ground integration tests import their helpers (ground_procs) from this folder."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
