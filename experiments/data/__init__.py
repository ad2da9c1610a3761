"""Synthetic data generators that simulate the papers' recording protocols, deterministic from a seed."""
