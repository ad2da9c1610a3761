"""Peers and baselines that several studies and benchmarks run beside ours."""
