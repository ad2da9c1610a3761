"""Does the volar grasps' tactile correction (MAP §III) fire, and what does it change?

Rolls out a handful of Small Diameter (or Large Diameter) trials with a 5 cm position error in a few
directions, each with and without the tactile correction, on the `native` backend (the MuJoCo C engine)
with the study's controller (`sim.grasp_strategy.controller_step`), logging every control step: which
links touch the object (touch sensor over the threshold and contact sensor with the object), the
phase, the number of corrections, the palm position. Prints one row per trial: the first touch
(time, links), the corrections (time, links, palm position there, goal before -> after), the palm
position when closing began, the palm's lateral offset from the object's true centre there, whether
the object was lifted. Self-contained; reads no test data. About 8 s on one core (12 trials).

    .venv/bin/python -m experiments.validation.tactile_correction [--hand barrett] [--grasp 2]
        [--directions 0 60 120 180 240 300] [--seeds 0 1] [--approach-speed 0.08]

`--approach-speed` is a counterfactual: it overrides the volar approach speed
(`grasp_strategy.SLOW_SPEED_M_S`, 0.08 m/s) for this process only.

What it showed (2026-12-03, Barrett and Karlsruhe, Small Diameter, 5 cm error): the correction fired
only where a fingertip touches first (object offset across the approach, 0 and 180 deg); there the
fingertip hit the 0.15 kg, 3 cm thin cylinder within 0.1 s of the start at full approach speed and the
hit alone toppled it (the object's trajectory was the same with and without the correction), so both
failed; elsewhere the palm touches first or nothing touches before the approach times out, and the
trials are identical. Besides, touch and `found` were peaks over the 10 substeps but the contact
positions were the last substep's: after a brief tap there was no position, c fell back to the old goal
and the correction retracted and re-approached along the same line (column c: "none").
After the fix (`peak_touch` keeps each contact's own substep; volar approaches at 0.08 m/s all the
way), the same command: every correction has its c, the object moves at most 5.1 mm in the 0.3 s after
a touch that starts a correction, and success with / without the correction is 1.00 / 0.67 (Barrett) and 0.92 / 0.58 (Karlsruhe).
"""
from __future__ import annotations

import argparse

import jax.numpy as jnp
import numpy as np

from sim.grasping import GRASP_NAMES
from sim.grasping import SUBSTEPS, native_start, peak_touch
from sim.grasping import trial_outcomes
from sim.grasping import (APPROACH, CLOSE, CONTROL_DT_S, DONE, RETRACT, TOUCH_THRESHOLD_N, n_control_steps,
    plan_trials)
from sim.hands import hand_spec


def logged_rollout(hand: str, params, object_start):
    """`grasp_rollout._rollout_native` (one thread) with a per-control-step log: (outcomes, log dict of (T, B, ...))."""
    model, layout, batch, control, state, sensordata, ctrl_view = native_start(hand, params, object_start, 1)
    b = params.goal.shape[0]
    log = {k: [] for k in ("phase", "n_corr", "goal", "palm", "touch", "found", "cpos", "obj")}
    obj = np.asarray(params.obj)
    for _ in range(n_control_steps()):
        # what the controller sees at this step
        touch = sensordata[:, layout.touch]
        found = sensordata[np.arange(b)[:, None], layout.contact[:, obj].T]
        log["touch"].append(touch > TOUCH_THRESHOLD_N)
        log["found"].append(found > 0)
        adr = layout.contact[:, obj].T                                    # (B, L)
        log["cpos"].append(sensordata[np.arange(b)[:, None, None], adr[..., None] + 1 + np.arange(3)])
        log["palm"].append(sensordata[:, layout.palm_pos:layout.palm_pos + 3].copy())
        pos_adr = layout.object_pos[obj]
        log["obj"].append(sensordata[np.arange(b)[:, None], pos_adr[:, None] + np.arange(3)])
        state, ctrl = control(state, jnp.asarray(sensordata, jnp.float32), params)
        log["phase"].append(np.asarray(state.phase))   # the phase decided from these readings
        log["n_corr"].append(np.asarray(state.n_corr))
        log["goal"].append(np.asarray(state.goal))
        ctrl_view[:] = np.asarray(ctrl)
        active = np.asarray(state.phase) != DONE
        if not active.any():
            break
        record = batch.rollout(SUBSTEPS, record=("sensordata",), ids=active)["sensordata"]
        sensordata[active] = peak_touch(record, layout)
    out = trial_outcomes(state, np.array(batch.bind("qpos")), layout, object_start, params.obj)
    return out, {k: np.stack(v) for k, v in log.items()}


def fmt(v) -> str:
    return "(" + ", ".join(f"{1e3 * x:+.0f}" for x in v) + ")"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--hand", default="barrett")
    ap.add_argument("--grasp", type=int, default=2)
    ap.add_argument("--offset-m", type=float, default=0.05)
    ap.add_argument("--directions", type=float, nargs="+", default=[0.0, 60.0, 120.0, 180.0, 240.0, 300.0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--approach-speed", type=float, default=None,
                    help="counterfactual only: override grasp_strategy.SLOW_SPEED_M_S (m/s) for this run")
    args = ap.parse_args(argv)
    if args.approach_speed is not None:   # read when the controller is first traced
        import sim._src.grasp_strategy as gs
        gs.SLOW_SPEED_M_S = args.approach_speed
    spec = hand_spec(args.hand)
    names = spec.link_names
    rows = [(d, s, tac) for d in args.directions for s in args.seeds for tac in (True, False)]
    ang = np.radians([r[0] for r in rows])
    offsets = args.offset_m * np.stack([np.cos(ang), np.sin(ang)], -1)
    params, object_start = plan_trials(spec.name, np.full(len(rows), args.grasp), offsets, np.zeros(len(rows)),
                                       np.array([r[2] for r in rows]), np.array([r[1] for r in rows]))
    out, log = logged_rollout(spec.name, params, object_start)
    a = np.asarray(params.approach)
    print(f"{spec.name}, {GRASP_NAMES[args.grasp]}, {1e3 * args.offset_m:.0f} mm position error; approach "
          f"{np.round(a[0], 2)}; links {names}; positions in mm (world); t in s"
          + (f"; COUNTERFACTUAL approach speed {args.approach_speed} m/s" if args.approach_speed is not None else ""))
    print("lat. off: palm's distance from the object's current centre across the approach when closing begins; "
          "obj moved: object displacement in the 0.3 s after the first touch; first touch: in any phase; c: mean contact "
          "position of the touching links in the controller's reading (`peak_touch`: touch at its peak over the 10 "
          "substeps, each contact as read in the last substep that found it): 'none' -> the controller falls back to "
          "c = goal (goal unchanged)")
    hdr = (f"{'dir':>4} {'seed':>4} {'tact':>4} | {'first touch (t: links)':<34} | {'corrections (t: links; c; palm; goal -> goal)':<90}"
           f" | {'close t':>7} {'palm at close':<18} {'lat. off':>8} | {'obj moved':>9} | {'lift mm':>7} {'ok':>3}")
    print(hdr)
    print("-" * len(hdr))
    for i, (d, s, tac) in enumerate(rows):
        touching = log["touch"][:, i] & log["found"][:, i]               # (T, L)
        phase = log["phase"][:, i]
        prev = np.concatenate([[APPROACH], phase[:-1]])
        k_touch = np.flatnonzero(touching.any(-1))
        first = (f"{k_touch[0] * CONTROL_DT_S:.2f}: " + ",".join(names[j] for j in np.flatnonzero(touching[k_touch[0]]))
                 if len(k_touch) else "none")
        corr = []
        for k in np.flatnonzero((phase == RETRACT) & (prev == APPROACH)):
            g0 = log["goal"][k - 1, i] if k else params.goal[i]
            # the controller's c: contact positions of the touching links in the reading (`peak_touch`)
            w = touching[k] & np.any(log["cpos"][k, i] != 0, -1)
            c = fmt(log["cpos"][k, i][w].mean(0)) if w.any() else "none"
            corr.append(f"{k * CONTROL_DT_S:.2f}: " + ",".join(names[j] for j in np.flatnonzero(touching[k]))
                        + f"; c {c}; palm {fmt(log['palm'][k, i])}; goal {fmt(g0)}->{fmt(log['goal'][k, i])}")
        k_close = np.flatnonzero((phase == CLOSE) & (prev != CLOSE))
        if len(k_close):
            kc = k_close[0]
            palm = log["palm"][kc, i]
            rel = palm - log["obj"][kc, i]
            lat = np.linalg.norm(rel - (rel @ a[i]) * a[i])
            close = f"{kc * CONTROL_DT_S:7.2f} {fmt(palm):<18} {1e3 * lat:8.1f}"
        else:
            close = f"{'never':>7} {'':<18} {'':>8}"
        # how far the object moved in the 0.3 s after the first touch (before any correction could act)
        k1 = min(k_touch[0] + 15, len(phase) - 1) if len(k_touch) else None
        moved = (f"{1e3 * np.linalg.norm(log['obj'][k1, i] - log['obj'][k_touch[0], i]):9.1f}" if k1 is not None
                 else f"{'-':>9}")
        print(f"{d:4.0f} {s:4d} {'on' if tac else 'off':>4} | {first:<34} | {' / '.join(corr) or 'none':<90} | "
              f"{close} | {moved} | {1e3 * out.lift_m[i]:7.1f} {'yes' if out.lifted[i] else 'no':>3}")
    for tac in (True, False):
        m = np.array([r[2] == tac for r in rows])
        print(f"tactile {'on ' if tac else 'off'}: success {out.lifted[m].mean():.2f}, corrections "
              f"{out.n_corrections[m].tolist()}, first touch on the palm {out.palm_first[m].tolist()}")


if __name__ == "__main__":
    main()
