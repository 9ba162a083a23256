"""`python benchmarks/headline.py`: runs :mod:`uav_penetration_env.benchmark.publishing.headline` (its docstring says what it writes)."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's package, from any folder

from uav_penetration_env.benchmark.publishing.headline import main

if __name__ == "__main__":
    sys.exit(main())
