"""Synthetic data generators that simulate the papers' recording protocols, deterministic from a seed,
and loaders of real recordings (`loaders`: marker files, images, video; `ue_adl`, `cdnet`: real data
sets) into the same in-memory formats."""
