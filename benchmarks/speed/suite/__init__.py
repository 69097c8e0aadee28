"""streamseg's speed suite (airspeed velocity): run it with ``python benchmarks/speed.py``."""
