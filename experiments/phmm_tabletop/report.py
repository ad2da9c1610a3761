"""report.md of the PHMM table-top study: our numbers beside the papers', and why they differ."""
from __future__ import annotations

from experiments.config import markdown_table
from experiments.data import tabletop as tt

DISCUSSION = """\
* **Data.** The papers' Vicon recordings are not public; every number here is on the simulated study
  of `experiments/data/tabletop/` (one seated subject, 60 Hz, 7 markers, 2 mm marker noise, 1.2 cm
  end-point scatter, occlusions filled by interpolation). Its variability is our design, not measured,
  so agreement or disagreement with the papers says how close the simulation is as much as how good
  the method is.
* **Synthesis and position errors** are within about 0.5 cm of the papers' ≈ 1.8 cm and ≈ 2 cm, and
  show the papers' pattern: the 3 x 3 PHMM is clearly better than the 2 x 2 one inside the raster.
  Part of our error is the reference itself: with 4 repetitions the 80-state HMM average still carries
  the repetitions' scatter (hand posture, sighting line and hold drift vary per repetition). The
  per-position 80-state HMMs are trained together (a shared global HMM, then per-position EM, the
  papers' synchronised training), which aligns them better than 35 independent fits would.
* **Classification.** On our data the task is easier for sequence models than on the papers': the
  3 x 3 PHMMs and the classical HMMs (trained on all positions) classify every noise-free test movement
  correctly, while the diagnostic features (peak hand height, largest hand-sternum distance, peak hand
  speed; logistic regression) are near chance, as the papers say such features would be. The simulated
  hand shapes differ (index extended vs. flexed around the object) and the simulation has no subject or
  session changes between training and test, both of which make full-trajectory models strong. The
  2 x 2 PHMMs classify worse than the 3 x 3 ones (the papers: 94 % vs 93 %); the per-action rates
  (table) and `classification_error_maps.png` show where: with seed 0 the 2 x 2 errors are reaching
  movements to the middle columns taken for pointing. Our reaching varies non-linearly across the
  raster (trunk turn and lean, the hand direction following the target's azimuth, the elbow lift over
  the table), so the bilinear blend of the four corner models describes reaching in the middle columns
  poorly (the 2 x 2 synthesis error is largest there too); the 3 x 3 grid has models in the middle
  column and does not have the problem.
* **Noise.** We are not as robust as the papers report (no significant effect below 15 cm): the
  position error grows from σ = 5 cm on and the classification rate drops from σ = 10 cm. Our local
  HMMs have full covariances estimated on clean 2 mm-noise data; i.i.d. noise of several cm on every
  coordinate is far outside them, so the likelihood is dominated by the noise term. The papers do not
  say which covariance model or floor they used. The fix here is the exact emission model of a
  noisy observation, Σ + σ² I (`phmm_jax.with_observation_noise`), with σ² read off the movements
  being recognised (`phmm_jax.estimate_noise_variance`, from second differences; it finds the
  simulated σ within 0.1 cm): the last columns of the noise table. It helps exactly as much as the
  noise is white and Gaussian, as it is in this simulation; real tracking noise is correlated over
  frames and heavier-tailed, and there the gain is unmeasured.
* **Log-likelihood surface.** It has one dominant, smooth peak near the true target (plot); the few
  other strict local maxima on the 41 x 41 grid are far lower (gap in the table). With a 3 x 3 grid the
  interpolation is bilinear per cell, so the surface has kinks along the cell borders (φ = 0.5); it is
  smooth within each cell.
* **Robot.** The robot arm (upper arm 10.5 cm, elbow to grasp point 14.5 cm) gets the human hand and
  elbow scaled by robot arm length / human arm length about the mean training shoulder position (papers
  §IV-A). The grasp-point error (robot scale) comes from the synthesised hand not quite reaching the
  mean grasp point and from far targets that the person reached by leaning the trunk, which the fixed
  robot shoulder cannot (the scaled hand is then out of reach and the arm stretches towards it). The
  robot elbow lies in the human shoulder-elbow-hand plane up to float32 round-off, and the solid table
  block (starting 5 cm nearer the body than the person's table, a stricter check) is never entered
  (minimum clearance in the table)."""


def report(cfg, m: dict) -> str:
    """report.md from the flat metrics `m` of a run with config `cfg`."""
    pct = lambda v: f"{100 * v:.1f} %"  # noqa: E731
    rows = [
        ("synthesis error, inner region, 3x3 (cm)", "≈ 1.8", f"{m['synthesis_error_cm_inner']:.2f}"),
        ("synthesis error, all positions, 3x3 (cm)", "larger at the border", f"{m['synthesis_error_cm_all']:.2f}"),
        ("synthesis error, inner / all, 2x2 (cm)", "larger than 3x3 inside",
         f"{m['synthesis_error_cm_inner_2x2']:.2f} / {m['synthesis_error_cm_all_2x2']:.2f}"),
        ("position error, inner / all, 3x3 (cm)", "≈ 2", f"{m['param_error_cm_inner']:.2f} / {m['param_error_cm_all']:.2f}"),
        ("position error, inner / all, 2x2 (cm)", "larger inside", f"{m['param_error_cm_inner_2x2']:.2f} / {m['param_error_cm_all_2x2']:.2f}"),
        ("baseline: linear regression from the final finger position, inner / all (cm)", "–",
         f"{m['param_error_cm_regression_inner']:.2f} / {m['param_error_cm_regression_all']:.2f}"),
        ("baseline: the same from index knuckle, index tip and thumb tip, inner / all (cm)", "–",
         f"{m['param_error_cm_regression_hand_inner']:.2f} / {m['param_error_cm_regression_hand_all']:.2f}"),
        ("classification, PHMM 2x2", "94 %", pct(m["classification_rate_phmm_2x2"])),
        ("classification, PHMM 3x3", "93 %", pct(m["classification_rate_phmm_3x3"])),
        ("classification, classical HMMs", "≈ 85 %", pct(m["classification_rate_hmm"])),
        *[(f"classification of {a} movements: PHMM 2x2 / 3x3 / HMMs", "–",
           " / ".join(pct(m[f"classification_rate_{c}_{a}"]) for c in ("phmm_2x2", "phmm_3x3", "hmm")))
          for a in tt.ACTIONS],
        ("classification, diagnostic features + logistic regression", "\"would fail\"",
         pct(m["classification_rate_diagnostic_baseline"])),
        ("local maxima of the log-likelihood surface (41 x 41 grid); gap of the second", "1 (smooth, concave)",
         f"{m['loglik_surface_local_maxima']}; {m['loglik_surface_second_maximum_gap']:.0f} of a range of "
         f"{m['loglik_surface_range']:.0f}"),
        ("robot reach error, mean / max (robot cm)", "–",
         f"{m['robot_reach_error_cm_mean']:.2f} / {m['robot_reach_error_cm_max']:.2f}"),
        ("robot elbow off the human arm plane, max (mm)", "0 by construction", f"{m['robot_elbow_plane_distance_mm_max']:.3f}"),
        ("robot arm-table clearance, min (cm); frames inside the table", "no collision",
         f"{m['robot_table_clearance_cm_min']:.2f}; {m['robot_frames_penetrating_table']} of {m['robot_frames']}"),
    ]
    noise_rows = [(f"{s:g}", m[f"param_error_cm_noise_{s:g}cm"], m[f"param_error_cm_noise_2x2_{s:g}cm"],
                   pct(m[f"classification_rate_noise_{s:g}cm"]), pct(m[f"classification_rate_noise_2x2_{s:g}cm"]),
                   pct(m[f"classification_rate_noise_hmm_{s:g}cm"]), m[f"noise_sigma_estimate_cm_{s:g}cm"],
                   m[f"param_error_cm_noise_aware_{s:g}cm"], pct(m[f"classification_rate_noise_aware_{s:g}cm"]),
                   m[f"param_error_cm_noise_regression_{s:g}cm"])
                  for s in sorted(set(cfg.noise_cm))]
    return "\n".join([
        "# PHMM table-top study (simulated motion capture)",
        "",
        f"{m['n_test_sequences']} test movements ({cfg.test_rows} x {cfg.test_cols} raster, {cfg.test_repetitions} "
        f"repetitions, both actions), {m['n_train_sequences']} training movements (3 x 3 raster, "
        f"{cfg.train_repetitions} repetitions). PHMMs of {cfg.n_states} states, durations {cfg.min_duration}-"
        f"{cfg.max_duration}, {cfg.n_samples} samples. Run time {m['runtime_s']:.0f} s.",
        "",
        markdown_table(["quantity", "paper (Humanoids/BMVC 2008)", "ours"], rows),
        "",
        "## Robustness to i.i.d. noise on every sample",
        "",
        markdown_table(["sigma (cm)", "position error 3x3 (cm)", "position error 2x2 (cm)", "rate 3x3",
                        "rate 2x2", "rate classical HMMs", "estimated sigma (cm)",
                        "position error 3x3, Σ + σ̂² I (cm)", "rate 3x3, Σ + σ̂² I",
                        "position error, regression from the final finger (cm)"], noise_rows),
        "",
        "Columns 7-9: the 3x3 PHMMs with the exact emission model of x = y + N(0, σ² I), "
        "Σ + σ̂² I, σ̂² estimated from each noise level's test movements themselves "
        "(`phmm_jax.estimate_noise_variance`, second differences): nothing is tuned on the test set. "
        "The last column: the baseline (an affine least-squares map per action from the index tip at the "
        "hold to the table position, fitted on the clean training movements) on the same noisy movements.",
        "",
        "## Why our numbers differ from the papers'",
        "",
        DISCUSSION,
        "",
        "![synthesis](synthesis_error_maps.png)",
        "![param](param_error_maps.png)",
        "![classification](classification_error_maps.png)",
        "![loglik](loglik_surface.png)",
        "![noise](noise_robustness.png)",
        "![robot](robot_trajectories.png)",
        "![robot frame](robot_frame.png)",
    ])
