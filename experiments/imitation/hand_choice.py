"""Which robot hand the loop uses, chosen on validation: the robot executes the recognised grasp class on
the demonstrated object, so a misrecognised class need not fail the task if the hand copes with it.

    python -m experiments.imitation.hand_choice --seed 1001 --n-demos 12 --out DIR

Two measurements, each for the Barrett and the Karlsruhe hand (MAP Fig. 2 mapping):

* every grasp class executed on every class's object (`sim.run_task`, the object alone where the task
  sweep puts it, two places of the sweep): the object's own class against the others;
* validation demonstrations (quick preset, a seed the test runs do not use): the loop's recognition run
  once per demonstration, then the robot's task with each hand; task success as `experiments.imitation`.

Writes hand_choice.json and hand_choice.md.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path


import sim
from experiments.config import markdown_table
from experiments.imitation import stages as st
from experiments.imitation.config import PRESETS, Config
from experiments.imitation.demonstrations import draw_demos
from lfd_common import enable_compilation_cache
from sim.grasping import GRASP_CLASSES, GRASP_NAMES

HANDS = ("barrett", "karlsruhe")
OBJECT_XY = (0.0, -0.40)
PLACES = ((0.20, -0.40), (-0.25, -0.35))


def cross_class_tasks(hand: str) -> list[dict]:
    """Every (object's class, executed class, place) task with `hand`: success and the failed stage."""
    rows = []
    for own in GRASP_CLASSES:
        for executed in GRASP_CLASSES:
            for place in PLACES:
                res = sim.run_task(sim.TaskSpec(objects=(own,), object_xy=[OBJECT_XY], target=0, grasp=executed,
                                                place_xy=place, hand=hand))
                rows.append(dict(hand=hand, object_class=own, executed=executed, place=place,
                                 success=bool(res.success), failed_stage=res.failed_stage))
                print(f"{hand:9s} object {own:2d} executed {executed:2d} place {place}: "
                      f"{'ok' if res.success else res.failed_stage}", flush=True)
    return rows


def validation_tasks(seed: int, n_demos: int) -> list[dict]:
    """The quick preset's loop on `n_demos` demonstrations of `seed`, the robot's task with each hand."""
    cfg = dataclasses.replace(Config(**PRESETS["quick"]), seed=seed, n_demos=n_demos)
    settings = cfg.video_settings()
    models, _, _ = st.prepare(cfg, settings)
    rows = []
    for k, demo in enumerate(draw_demos(n_demos, seed, cfg.demonstrators, cfg.handover_xy)):
        out = st.run_demo(cfg, settings, models, demo, robot=False)
        r = out["recognised"]
        row = dict(demo=k, kind=demo.kind, kind_recognised=r.kind, grasp=demo.grasp, grasp_recognised=r.grasp,
                   first_wrong_stage=out["failed_stage"] or "")
        for hand in HANDS:
            if r.kind is None:
                row[hand] = dict(success=False, failed_stage="no movement recognised")
                continue
            hand_cfg = dataclasses.replace(cfg, robot_hand=hand)
            res = st.robot_task(hand_cfg, demo, r, models.phmms)
            row[hand] = dict(success=st.task_done(hand_cfg, demo, r, res), failed_stage=res.failed_stage)
        rows.append(row)
        print(row, flush=True)
    return rows


def report(cross: list[dict], demos: list[dict], seed: int) -> str:
    """The two tables as markdown."""
    def share(rows):
        return f"{sum(r['success'] for r in rows)} of {len(rows)}"

    cross_rows = []
    for hand in HANDS:
        mine = [r for r in cross if r["hand"] == hand]
        cross_rows.append((hand, share([r for r in mine if r["object_class"] == r["executed"]]),
                           share([r for r in mine if r["object_class"] != r["executed"]])))
    per_class = [(f"{g} {GRASP_NAMES[g]}",) + tuple(
        share([r for r in cross if r["hand"] == hand and r["executed"] == g and r["object_class"] != g])
        for hand in HANDS) for g in GRASP_CLASSES]
    demo_rows = [(r["demo"], r["kind"], r["kind_recognised"], f"{r['grasp']} / {r['grasp_recognised']}",
                  r["first_wrong_stage"] or "none")
                 + tuple("done" if r[h]["success"] else f"not done ({r[h]['failed_stage'] or 'robot finished; object or place wrong'})" for h in HANDS)
                 for r in demos]
    totals = [share([r[h] for r in demos]) for h in HANDS]
    return "\n".join([
        "# Robot hand of the loop", "",
        f"Tasks with the object alone at {OBJECT_XY}, places {PLACES}: the object's own grasp class against the "
        "other five classes executed on it.", "",
        markdown_table(["hand", "own class", "another class"], cross_rows), "",
        "Another class executed, by the class executed:", "",
        markdown_table(["executed class", *HANDS], per_class), "",
        f"Validation demonstrations (quick preset, seed {seed}): the same recognitions, the robot's task with each "
        "hand (grasp: demonstrated / recognised).", "",
        markdown_table(["demo", "action", "recognised", "grasp", "first wrong stage", *HANDS], demo_rows), "",
        "Task success: " + ", ".join(f"{h} {t}" for h, t in zip(HANDS, totals)) + "."])


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(prog="python -m experiments.imitation.hand_choice",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=1001, help="the validation demonstrations' seed")
    parser.add_argument("--n-demos", type=int, default=12, help="validation demonstrations")
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    args = parser.parse_args(argv)
    if args.n_demos < 1:
        parser.error("--n-demos: expected at least 1")
    enable_compilation_cache()
    cross = [row for hand in HANDS for row in cross_class_tasks(hand)]
    demos = validation_tasks(args.seed, args.n_demos)
    args.out.mkdir(parents=True, exist_ok=True)
    result = {"cross_class": cross, "validation": demos, "seed": args.seed}
    (args.out / "hand_choice.json").write_text(json.dumps(result, indent=1, default=float))
    text = report(cross, demos, args.seed)
    (args.out / "hand_choice.md").write_text(text + "\n")
    print(text)
    return result


if __name__ == "__main__":
    main()
