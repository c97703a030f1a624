"""CLI: ``python -m walker_gait.synth --scenario normal --duration 10 --out s.mcap``."""

from __future__ import annotations

import sys

from walker_gait.synth.cli import main

if __name__ == "__main__":
    sys.exit(main())
