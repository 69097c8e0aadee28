"""Standalone client scripts (thin wrappers of the ``streamseg`` subcommands)."""
