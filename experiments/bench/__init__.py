"""Benchmarks against the anchor libraries: `python -m experiments.bench.bench_NAME --preset quick`."""
