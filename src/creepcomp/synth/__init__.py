"""Synthetic records with known hidden effects, for tests and benchmarks."""
