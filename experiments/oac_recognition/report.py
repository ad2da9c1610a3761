"""report.md of the OAC study: every cell beside the paper's, the papers' conclusions checked, and
where the simulation differs."""
from __future__ import annotations

import numpy as np

from experiments.config import markdown_table
from experiments.data import oac
from experiments.data.oac_protocol import (PAPER_LFD_CORRECT, PAPER_TABLE2, PAPER_TABLE3, PAPER_TABLE4,
                                          TABLE4_CELLS)
from experiments.oac_recognition.config import Config


def _cell(ours: dict, paper) -> tuple[str, str]:
    mine = f"{ours['median']:.1f} ({ours['max']:.1f})"
    if paper is None:
        return mine, "-"
    med, mx = paper
    return mine, f"{med:g} ({mx:g})" if mx is not None else f"{med:g}"


def conclusions(t: dict) -> list[tuple[str, bool, str]]:
    """The papers' claims, checked on our medians: (claim, holds, evidence)."""
    m = lambda *keys: _get(t, keys)["median"]  # noqa: E731
    out = []
    for tgt in ("actions", "objects"):
        c0, c2, h = m("table2", tgt, "crf_conn0"), m("table2", tgt, "crf_conn2"), m("table2", tgt, "hcrf_conn0")
        out.append((f"{tgt}: simpler CRFs beat the HCRF and higher connectivity on little data",
                    c0 <= h and c0 <= c2, f"conn 0 {c0:.1f} %, conn 2 {c2:.1f} %, HCRF {h:.1f} %"))
    for tgt in ("actions", "objects"):
        ch, fc, sep = m("table3", tgt, "chcrf"), m("table3", tgt, "fcrf"), m("table3", tgt, "separate_crf")
        out.append((f"{tgt}: CHCRF beats FCRF and separate CRFs", ch < fc and ch < sep,
                    f"CHCRF {ch:.1f} %, FCRF {fc:.1f} %, separate {sep:.1f} %"))
    full = max(m("table4", "xa_xo", "actions"), m("table4", "xa_xo", "objects"))
    one = max(m("table4", c, k) for c in ("pa_xo", "xa_x1o") for k in ("actions", "objects"))
    none = max(m("table4", "pa_x1o", "actions"), m("table4", "pa_x1o", "objects"))
    out.append(("the two cues are redundant: removing either costs little, removing both costs much",
                none - full > 0 and one - full < 0.5 * (none - full),
                f"full {full:.1f} %, worst single removal {one:.1f} %, both removed {none:.1f} %"))
    p2, p3 = m("table_lfd", "2d", "pos_only"), m("table_lfd", "3d", "pos_only")
    s2, s3 = m("table_lfd", "2d", "shape_and_pos"), m("table_lfd", "3d", "shape_and_pos")
    out.append(("LfD: 3-D position beats 2-D position alone; with shape the difference shrinks",
                p3 < p2 and abs(s3 - s2) < abs(p3 - p2), f"pos only 2-D {p2:.1f} % / 3-D {p3:.1f} %; "
                f"with shape 2-D {s2:.1f} % / 3-D {s3:.1f} % (error)"))
    return out


def _get(tree: dict, keys) -> dict:
    for k in keys:
        tree = tree[k]
    return tree


def report_tables(t: dict) -> list[str]:
    """Markdown: every cell as 'ours median (max)' beside 'paper median (max)'."""
    lines = ["### Table 2: separate action and object classification, error % median (max)", ""]
    rows = []
    for tgt in ("actions", "objects"):
        for method, ours in t["table2"][tgt].items():
            label = method if method != "baseline" else ("baseline: 2-D position only" if tgt == "actions"
                                                         else "baseline: SVM on the first frame")
            rows.append((tgt, label, *_cell(ours, PAPER_TABLE2[tgt][method])))
    lines += [markdown_table(["", "classifier", "ours", "paper"], rows), ""]
    lines += ["### Table 3: late (CHCRF) vs early (FCRF) fusion, connectivity 0, error % median (max)", ""]
    rows = [(tgt, m, *_cell(t["table3"][tgt][m], PAPER_TABLE3[tgt][m])) for tgt in ("actions", "objects")
            for m in ("chcrf", "fcrf", "separate_crf")]
    lines += [markdown_table(["", "model", "ours", "paper"], rows), ""]
    lines += ["### Table 4: CHCRF with either or both cues replaced by their baseline, error % median (max)", "",
              "Cells: action data x^a (position + hand HOG) or p^a (2-D position only); object data x^o "
              "(HOG sequence) or x^o_1 (SVM on the first frame). The paper gives one number per cell (its "
              "K is diagonal, so action and object errors coincide); we give both.", ""]
    names = {"xa_xo": "x^a, x^o", "pa_xo": "p^a, x^o", "xa_x1o": "x^a, x^o_1", "pa_x1o": "p^a, x^o_1"}
    rows = [(names[c], *_cell(t["table4"][c]["actions"], PAPER_TABLE4[c])[:1], _cell(t["table4"][c]["objects"], None)[0],
             _cell(t["table4"][c]["actions"], PAPER_TABLE4[c])[1]) for c in TABLE4_CELLS]
    lines += [markdown_table(["cues", "ours: actions", "ours: objects", "paper"], rows), ""]
    lines += ["### LfD Table I: action classification, % correct (median of runs; error max in brackets)", ""]
    rows = []
    for dim in ("2d", "3d"):
        for kind in ("shape_and_pos", "pos_only"):
            e = t["table_lfd"][dim][kind]
            rows.append((dim.upper(), kind.replace("_", " "), f"{100 - e['median']:.1f} (worst {100 - e['max']:.1f})",
                         f"{PAPER_LFD_CORRECT[dim][kind]:g}"))
    lines += [markdown_table(["position", "features", "ours % correct", "paper % correct"], rows), ""]
    return lines


def differences(t: dict, cfg: Config) -> list[str]:
    """Markdown bullets: what the simulation does differently from the papers' recordings, with our numbers."""
    m = lambda *keys: _get(t, keys)["median"]  # noqa: E731
    persons = oac.draw_persons(np.random.default_rng(cfg.seed), cfg.n_persons)
    by_handle = sum(p.cup_by_handle for p in persons)
    return [
        "- Data: simulated, not the papers' 150 videos (see `experiments/data/oac/`). Hand views are "
        "MuJoCo renderings of the `sim.human_hand` model in the grasp each object implies, segmented the "
        "skin-colour way (the face joins the hand mask when they touch), with motion blur, a one-pixel "
        "boundary error and a bounding-box crop. They still separate the actions better than real video: "
        f"every action classifier with hand shape is at {m('table2', 'actions', 'crf_conn0'):.1f} % "
        "(conn 0) against the paper's 5.3 %, so the action rows of Table 3 cannot show a fusion gain.",
        "- Objects: one instance per class, made ambiguous the papers' way (one HOG level, square "
        f"window, occlusion by the hand); in addition {by_handle} of {cfg.n_persons} persons (drawn with "
        "probability 0.3) hold the cup by its handle, "
        "as everyone holds the pitcher, and then cup and pitcher look alike. Separate object "
        f"classification is therefore weaker than the paper's ({m('table2', 'objects', 'crf_conn0'):.1f} % vs "
        f"8 %), and fusing it with the (near-perfect) action cue gains more ({m('table3', 'objects', 'chcrf'):.1f} "
        "% with the CHCRF); for the same reason replacing x^a by p^a costs more in Table 4 than in the paper.",
        "- FCRF: exact inference in the 9-state product space (the papers used loopy BP), and both chains "
        "see all features [p, hand HOG, object HOG], so the object chain gets the hand cue directly "
        f"(objects {m('table3', 'objects', 'fcrf'):.1f} %); the papers' FCRF was worse than their CHCRF, "
        "which they attribute to its larger parameter set on little data.",
        "- HCRF on objects: with 4 object features per frame the HCRF has few parameters and its hidden "
        "states can follow the view phases (lift, tilt, put down), so it is not penalised the way the "
        f"papers' was (objects: HCRF {m('table2', 'objects', 'hcrf_conn0'):.1f} %, CRF conn 0 "
        f"{m('table2', 'objects', 'crf_conn0'):.1f} %).",
        "- Hand position: the true hand centre plus AR(1) centroid noise (2.5 px, 6 px more while the hand "
        "blob touches the face) and 1 px left/right disagreement (about 6 cm depth noise at 1.6 m); the "
        "persons' target offsets (2.5 cm) and the look-through / drink targets (9 cm apart) are "
        "anthropometric guesses, not fitted to the papers' numbers.",
        "- A 'run' is a full leave-one-person-out pass; the papers do not say what differs between their 9 "
        "runs. With convex CRFs, runs here differ only through the early-stopping validation person "
        "(training uses 8 of the 9 other persons) and the HCRF initialisation, so spreads (max - median) "
        "are smaller than the papers'.",
        f"- Training: L-BFGS (optax) with L2 c2 = {cfg.l2:g} for every CRF, at most {cfg.max_iter} "
        f"iterations, early stopping on the validation person; HCRF with {cfg.n_hidden} hidden states per "
        f"class; SVM (hinge, Adam) with L2 {cfg.svm_l2:g}; co-occurrence smoothing {cfg.cooc_smoothing:g}.",
    ]


def report(cfg: Config, data: oac.OACData, t: dict, runtime: float, data_s: float) -> str:
    """report.md: the data set, every table beside the paper's, the conclusions, the differences."""
    checks = conclusions(t)
    return "\n".join([
        "# OAC: simultaneous recognition of manipulation actions and manipulated objects", "",
        f"Simulated OAC data set: {len(data.action)} recordings ({cfg.n_persons} persons x "
        f"{cfg.n_repetitions} repetitions x 3 classes), {cfg.fps:g} frames/s, {data.lengths.mean():.1f} frames on "
        f"average; hand HOG {data.hand_hog.shape[-1]}-D (B = 4, L = 3), object HOG {data.object_hog.shape[-1]}-D "
        "(B = 4, L = 1, square-normalised window, as ECCV §5). "
        f"{cfg.n_runs} runs of a full leave-one-person-out pass (the error of a run is over all recordings; "
        "runs differ in the early-stopping validation person of each fold and the HCRF initialisation). "
        f"Run time {runtime:.0f} s (data {data_s:.0f} s, from the cache when present).", "",
        *report_tables(t),
        "### The papers' conclusions on our data", "",
        markdown_table(["claim", "holds here", "evidence (median error)"],
                       [(c, "yes" if ok else "**no**", ev) for c, ok, ev in checks]), "",
        "### Where and why we differ from the papers", "",
        *differences(t, cfg), "",
        "![trajectories](trajectories.png)", "", "![views](views.png)", "", "![errors](errors.png)",
    ])
