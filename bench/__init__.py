"""Benchmarks of the radiosity baker: ``python -m bench <study>`` measures and writes a report into docs/results/."""
