"""report.md of the skin study on real photos."""
from __future__ import annotations

from experiments.config import markdown_table

_ROWS = (("ours", "ours: hog_jax skin GMMs (UCI pixels) + 3 x 3 median x 3"),
         ("ycrcb", "YCrCb rule (Chai & Ngan 1999) + the same median filter"),
         ("ycrcb_unfiltered", "YCrCb rule alone (cv2.inRange recipe)"),
         ("grabcut", "GrabCut seeded by ours"))
_TIMES = {"ours": "time_s_ours", "ycrcb": "time_s_ycrcb", "grabcut": "time_s_grabcut"}


def _f(value, digits=3) -> str:
    return "–" if value is None or value != value else f"{value:.{digits}f}"


def report(cfg, m: dict, runtime_s: float) -> str:
    """The markdown report from the run's (flat) metrics."""
    rows = [[label, _f(m[f"precision_{k}"]), _f(m[f"recall_{k}"]), _f(m[f"iou_{k}"]),
             _f(m[f"iou_per_photo_mean_{k}"]), _f(m[f"hand_found_rate_{k}"]),
             _f(m[_TIMES[k]], 1) if k in _TIMES else "(with the row above)"] for k, label in _ROWS]
    table = markdown_table(["method", "precision", "recall", "IoU (pooled)", "IoU (mean per photo)", "hand found",
                            "time (s)"], rows)
    curve = ", ".join(f"{t:g}: {_f(v)}" for t, v in zip(m["curve_thresholds"], m["curve_iou_ours"]))
    chosen = ("chosen on the held-out UCI pixels (the IoU-best threshold of the unfiltered per-pixel rule; "
              "the HGR photos were never used to choose anything)" if m["threshold_source"] == "uci_validation"
              else "given on the command line")
    return f"""# Skin segmentation on real photos

Skin model: `hog_jax.fit_skin_model` (skin and non-skin Gaussian mixtures of {cfg.n_components} and
{cfg.n_background} components over BT.601 (Cr, Cb), {cfg.n_iter} EM iterations) fitted on {m['uci_fit_pixels']:,}
pixels of the UCI Skin Segmentation set (Bhatt & Dhall; face photos); {m['uci_validation_pixels']:,} other UCI
pixels held out. Threshold on the log ratio: **{m['threshold_ours']:.3f}**, {chosen}. On the held-out UCI pixels
it gives IoU {_f(m['uci_validation_iou_ours'])} (precision {_f(m['uci_validation_precision_ours'])}, recall
{_f(m['uci_validation_recall_ours'])}); the natural threshold 0 (equal priors) gives
{_f(m['uci_validation_iou_ours_threshold_0'])}.

Test: {m['n_photos']} photos of HGR1 (Kawulok, Kawulok, Nalepa & Smolka, EURASIP JASP 2014), {m['n_pixels']:,}
pixels, true skin (hand and forearm) {100 * m['true_skin_fraction']:.1f} % of a photo on average. Pooled scores
sum the pixel counts of all photos; the mean per photo averages each photo's IoU.

{table}

**Hand found**: the largest 8-connected component of the method's mask has IoU >= {cfg.hand_iou:g} with the
photo's true skin mask (no skin found: not found). Mean IoU of that largest component: ours
{_f(m['largest_component_iou_mean_ours'])}, YCrCb {_f(m['largest_component_iou_mean_ycrcb'])}, GrabCut
{_f(m['largest_component_iou_mean_grabcut'])}.

Ours over thresholds on the photos (to read, not to choose: pooled IoU at each log-ratio threshold):
{curve}.

Peers: the YCrCb rule is the fixed chroma box Cr in [133, 173], Cb in [77, 127] (Chai & Ngan, "Face
segmentation using skin-color map in videophone applications", IEEE TCSVT 9(4), 1999), the common OpenCV
recipe `cv2.inRange(cv2.cvtColor(img, cv2.COLOR_BGR2YCrCb), (0, 133, 77), (255, 173, 127))`, computed here
bit for bit in JAX. GrabCut (Rother, Kolmogorov & Blake 2004; `cv2.grabCut`, {cfg.grabcut_iterations} iterations;
its time excludes ours)
starts from our mask: probable foreground where ours says skin, probable background elsewhere
({m['grabcut_not_run']} photo(s) where our mask was all one label kept it unchanged).

Times on this machine: JAX compilation {m['compile_s']:.1f} s (apart); ours is the log ratio and the median
filter in batches of {cfg.batch_size} padded photos; the precision/recall curve over {len(cfg.curve_thresholds)}
thresholds took {m['time_s_curve']:.1f} s more, the connected components of all methods {m['time_s_components']:.1f} s,
reading the photos {m['load_s']:.1f} s, fitting the model {m['fit_s']:.1f} s. Run time {runtime_s:.0f} s.

Figures: `contact_sheet.png` (photos, truth, each method's errors), `precision_recall.png` (ours over
thresholds on the photos and on the held-out UCI pixels, every method's operating point);
`per_photo.csv` has each photo's IoU and hand-found flag.
"""


_VARIANT_LABELS = {"ycrcb": "YCrCb rule (Chai & Ngan 1999) + median", "generic": "ours, generic",
                   "rules": "ours + rules", "adapted": "ours + adapted"}


def one_model_report(cfg, m: dict) -> str:
    """The markdown report of the one-model study from its (nested) metrics."""
    settings, val = m["settings"], m["validation"]
    adapted_label = f"ours + {'rules + ' if val['adapted_on'] == 'rules' else ''}adapted"
    labels = {**_VARIANT_LABELS, "adapted": adapted_label}
    rows = []
    for v in ("ycrcb", "generic", "rules", "adapted"):
        h = m["hgr_test"][v]
        g = m.get("gtea", {}).get(v, {})
        rows.append([labels[v], _f(h["iou"]), _f(h["iou_per_photo_mean"]), _f(h["hand_found_rate"]),
                     _f(g.get("in_box_skin")), _f(g.get("skin_outside_boxes")), _f(g.get("hands_found_rate")),
                     _f(m["reach_skin_fraction"].get(v))])
    for key in m["hgr_test"]:
        if key.startswith("generic_"):
            h, g = m["hgr_test"][key], m.get("gtea", {}).get(key, {})
            rows.append([f"ours, generic, {key[8:]} (space not chosen)", _f(h["iou"]), _f(h["iou_per_photo_mean"]),
                         _f(h["hand_found_rate"]), _f(g.get("in_box_skin")), _f(g.get("skin_outside_boxes")),
                         _f(g.get("hands_found_rate")), "–"])
    table = markdown_table(["method", "HGR test IoU (pooled)", "IoU (mean/photo)", "hand found",
                            "gtea: box pixels skin", "gtea: skin outside boxes", "gtea: hands found",
                            "reach: frame marked"], rows)
    rule_rows = [[k, _f(r["threshold"], 2), _f(r["hgr_iou"]), _f(r["uci_iou"]), _f(r["score"])]
                 for k, r in val["rule_sets"].items()]
    rule_table = markdown_table(["rules on", "threshold", "HGR val IoU", "UCI val IoU", "score"], rule_rows)
    rel = ", ".join(f"r = {k}: {_f(r['hgr_iou'])} (threshold {r['threshold']:g})" for k, r in val["relevance"].items())
    spaces = ", ".join(f"{k}: {_f(r['score'])} (HGR {_f(r['hgr_iou'])}, threshold {r['threshold']:g})"
                       for k, r in val["spaces"].items())
    rf = m["rules_fitted"]
    n = m["n_fit"]
    static = m["reach_skin_fraction"].get("rules + static")
    return f"""# One skin model on real photos and frames

Model: `hog_jax.fit_skin_model` (skin / non-skin GMMs of {cfg.n_components} / {cfg.n_background} components over
BT.601 (Cr, Cb) or (Cr, Cb, Y), {cfg.n_iter} EM iterations) on {cfg.fit_sources}: {n}. HGR photos split by person: fitted on
{', '.join(cfg.hgr_fit_ids)}, settings chosen on {', '.join(cfg.hgr_validation_ids)} (+ {cfg.uci_validation_pixels:,}
held-out UCI pixels), reported on the other persons ({m['split']['test']} photos); photos at scale
{cfg.photo_scale:g}; the validation photos also enter with their RGB values scaled by
{', '.join(f'{e:g}' for e in cfg.validation_exposures)} (a stand-in for other light). Nothing was chosen on the
test photos, gtea_grasps or the reach clip.

Colour space (validation score of the generic model, mean of the HGR validation and UCI held-out IoUs):
{spaces}; chosen **{val['space_chosen']}** (crcb: (Cr, Cb); crcby: (Cr, Cb, Y), luminance-dependent).

Rule bounds learnt from the fitting photos' true skin (each keeps all but {100 * cfg.rule_quantile:g} % on its side):
luma in [{rf['min_luma']:.3f}, {rf['max_luma']:.3f}], saturation <= {rf['max_saturation']:.3f}, texture (std of
Y/255 in {rf['window']} x {rf['window']}) <= {rf['max_texture']:.3f}. Validation (score = mean of the two IoUs):

{rule_table}

Chosen: rules **{val['rules_chosen']}** (threshold {settings['rules']['threshold']:g}); generic threshold
{settings['generic']['threshold']:g}. Adaptation (on the {val['adapted_on']} variant; the most confident blob, log
ratio > threshold + {cfg.adapt_margin:g}, eroded 2 px, Reynolds MAP of the skin means and weights), HGR validation
IoU per relevance: {rel}; chosen r = {val['relevance_chosen']:g} (ties within {cfg.relevance_tolerance:g}: the
larger r). YCrCb on the validation photos:
{_f(val['hgr_iou_ycrcb'])}.

{table}

gtea_grasps ({m.get('gtea', {}).get('generic', {}).get('n_hands', 0)} hands, frames at scale {cfg.gtea_scale:g}):
the drawn annotation (box bands, pure-colour lines and red text near the boxes) is left out of every
count. "box pixels skin": share of the true hand boxes' pixels marked skin (boxes also hold objects,
so 1 is not the ideal); "skin outside boxes": share of marked pixels outside every hand box (lower is
better); "hands found": true boxes matched by the k largest blobs (k = the frame's hands) at box IoU >= 0.5.
Reach clip: no truth; `reach_sheet.png` shows the masks; "rules + static" (the static-background
rule, background = the clip's temporal median) marks {_f(static)} of the frame.

Times: fit {m['fit_s']:.1f} s, validation {m['choose_s']:.1f} s, total {m['total_s']:.0f} s.
"""
