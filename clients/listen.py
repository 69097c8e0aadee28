"""Standalone client: same as `streamseg listen` (see streamseg/commands/listen.py)."""

import sys

from streamseg.cli import main

if __name__ == "__main__":
    sys.exit(main(["listen", *sys.argv[1:]]))
