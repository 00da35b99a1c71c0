#!/usr/bin/env python3
"""Render a Mitsuba 3 scene sparsely and complete it: see `python -m gmcpt --help`."""
import sys

from gmcpt.cli import main

if __name__ == "__main__":
    sys.exit(main())
