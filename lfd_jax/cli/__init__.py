"""`lfd-jax`, the command line for one's own data. Installed as a console script
(`[project.scripts]` in pyproject.toml); `python -m lfd_jax.cli` is the same.

    lfd-jax grasp IMAGE... [--db PATH] [--build-db] [--db-size N] [--out DIR]
    lfd-jax phmm fit DIR --out MODEL [--label REGEX] [--config JSON] [--n-states N ...]
    lfd-jax phmm recognize MODEL FILE... [--label REGEX]
    lfd-jax video VIDEO --out DIR [--right VIDEO --focal-px F --baseline-m B] [--start N]

`lfd-jax SUBCOMMAND --help` describes each. The work is done by the libraries and
`lfd_jax`: `grasp` by `sim.grasping.view_database` (the rendered database), `hog_jax` (skin segmentation,
HOG, kNN), `lfd_jax.grasp` and `sim.grasping.robot_grasp_for`;
`phmm` by `lfd_jax`'s marker readers and `phmm_jax`; `video` by `hog_jax.video` and the tracker.
Bad input ends in one line on stderr (`lfd-jax: error: ...`) and exit status 2.
"""
from lfd_jax.cli._src.app import build_parser, main

__all__ = ["build_parser", "main"]
