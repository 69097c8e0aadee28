"""Standalone client: same as `streamseg replay` (see streamseg/commands/replay.py)."""

import sys

from streamseg.cli import main

if __name__ == "__main__":
    sys.exit(main(["replay", *sys.argv[1:]]))
