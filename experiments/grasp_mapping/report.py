"""report.md of the grasp mapping study."""
from __future__ import annotations

import numpy as np

from experiments.config import markdown_table
from experiments.grasp_mapping.config import Config, conditions
from experiments.grasp_mapping.trials import finite_mean
from sim.grasping import GRASP_NAMES, VOLAR_GRASPS, robot_grasp_for


def report(cfg: Config, results: dict, tables: dict, claim_rows: list, flat: dict) -> str:
    """report.md: setup, the four claims, per-grasp tables, figures."""
    lines = ["# Grasp mapping (MAP §IV-A) in MuJoCo", "",
             f"{flat['trials']} trials ({', '.join(results)}; grasps {', '.join(map(str, cfg.grasps))}; "
             f"{len(conditions(cfg))} conditions; {cfg.n_seeds} seeds; volar grasps with and without tactile "
             f"correction) on backend `{flat['backend']}` in {flat['runtime_s']:.1f} s "
             f"(rollout {flat['rollout_s']:.1f} s, {flat['physics_steps']:,} physics steps).", "",
             "The paper (GraspIt!, no dynamics) measured virtual-finger errors only; we also lift and hold. "
             "VF errors average the trials whose robot hand touched the object (a lower bound, as in the "
             "paper); `no contact` rates and success rates show the rest.", "",
             "## The paper's claims", "",
             markdown_table(["claim", "confirmed here", "our numbers"],
                            [(c, "yes" if ok else "no", ev) for c, ok, ev in claim_rows]), ""]
    for hand in results:
        lines += [f"## {hand}", "", f"success rate {flat[f'success_rate_{hand}']:.2f} overall, "
                  f"{flat[f'success_rate_{hand}_no_error']:.2f} without error; slip during the hold (lifted "
                  f"trials): median {flat[f'slip_mm_{hand}_median']:.1f} mm, 95th percentile "
                  f"{flat[f'slip_mm_{hand}_p95']:.1f} mm; {100 * flat[f'unfinished_rate_{hand}']:.0f} % of trials "
                  "had not finished (held 1 s) by the end of the horizon.", ""]
        rows = []
        for g in cfg.grasps:
            name = GRASP_NAMES[g]
            labels = ["none", "pos", *(f"rot_{t:g}deg" for t in cfg.tilts_deg)]
            pos_names = [c.name for c in conditions(cfg) if c.kind == "pos"]

            def cell(key, label, suffix=""):
                t = tables[key][hand][name]
                vals = [t[n + suffix] for n in (pos_names if label == "pos" else [label])]
                return finite_mean(np.array(vals))
            rows.append((f"{g} {name}", robot_grasp_for(g, hand, cfg.mapping),
                         *[f"{cell('vf_position_error_mm', lab):.1f} / {cell('vf_orientation_error_deg', lab):.0f} / "
                           f"{cell('success', lab):.2f}" for lab in labels],
                         f"{cell('vf_position_error_mm', 'pos', '_no_tactile'):.1f} / "
                         f"{cell('success', 'pos', '_no_tactile'):.2f}" if g in VOLAR_GRASPS else "open loop"))
        lines += [markdown_table(["human grasp", "robot grasp", "no error", "position 5 cm",
                                  *(f"rotation {t:g} deg" for t in cfg.tilts_deg), "position, no tactile"], rows),
                  "", "Cells: VF position error (mm) / VF orientation error (deg) / success rate.", ""]
    lines += ["## Figures", "", "![fig4](fig4.png)", "", "![success](success.png)", "", "![frames](frames.png)", "",
              "Frames: the no-error trial of each grasp (columns: " + ", ".join(map(str, cfg.grasps))
              + "; rows: " + ", ".join(results) + ") at the end of the 1 s hold."]
    return "\n".join(lines)
