"""Make the report tests' shared synthetic tables (report_synth.py) importable."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
