"""Skin segmentation on real photos.

    python -m experiments.skin_real --data ../shared/data --preset quick|paper --out DIR

`hog_jax`'s skin model (`fit_skin_model`: skin and non-skin GMMs over chroma) fitted on the UCI Skin
Segmentation pixels, its log-ratio threshold chosen on held-out UCI pixels (or `--threshold`), then
evaluated on the 106 real hand photos of HGR1 with their skin masks, as `hog_jax.segment` makes its
skin mask (threshold, 3 x 3 median filter three times); beside the fixed YCrCb rule of Chai & Ngan
(1999) and OpenCV's GrabCut seeded by our mask. Scores: pixel precision, recall and IoU (pooled over
pixels and the mean per photo) and the rate of photos whose largest skin component is the hand
(IoU >= 0.5 with the true mask). Without the data folder the study exits with a one-line message.

Outputs: metrics.json, report.md, contact_sheet.png, precision_recall.png, per_photo.csv.

    python -m experiments.skin_real --data ../shared/data --preset model_quick|model --out DIR

The one-model study (`one_model.py`): skin / non-skin GMMs fitted on UCI pixels and the HGR photos of
some persons, the colour space ((Cr, Cb) or (Cr, Cb, Y)), threshold, rules for skin-coloured non-skin
and the relevance of the adaptation to each image's most confident skin blob chosen on other persons
(+ held-out UCI pixels), reported on the remaining persons, gtea_grasps (hand boxes) and the reach
clip (contact sheet), beside the YCrCb rule. Outputs: metrics.json, report.md, skin_model.npz,
reach_sheet.png, gtea_sheet.png.
"""
from experiments.skin_real.config import PRESETS, Config
from experiments.skin_real.stages import main

__all__ = ["PRESETS", "Config", "main"]
