"""Standalone client: same as `streamseg serve` (see streamseg/commands/serve.py)."""

import sys

from streamseg.cli import main

if __name__ == "__main__":
    sys.exit(main(["serve", *sys.argv[1:]]))
