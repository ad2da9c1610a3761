"""One skin model for stills and video: fitted on real pixels, settings chosen on validation, reported
on every real set beside the YCrCb rule.

* Fit: `hog_jax.fit_skin_model` (skin and non-skin GMMs over BT.601 (Cr, Cb), and over (Cr, Cb, Y):
  a luminance-dependent model) on a sample of the UCI pixels (fitting part) and of the HGR photos of
  the fitting persons (`lfd_jax.load_mask_pixels`); the colour space is chosen on validation.
* Variants: generic (log ratio > threshold, 3 x 3 median x 3); + rules (`hog_jax.fit_skin_rules`
  bounds on luma, saturation, texture, learnt from the fitting photos' true skin; which of them
  are on is chosen on validation); + adapted (the most confident skin blob of each image, eroded, is
  the person's skin sample (at most 4,096 of its pixels, at random): `hog_jax.adapt_to_skin`, Reynolds relevance MAP of the skin means and
  weights; the relevance chosen on validation, ties within `relevance_tolerance` going to the larger
  relevance, the smaller step from the generic model).
* Validation: HGR photos of other persons (also with their values scaled by each of
  `validation_exposures`, a stand-in for other light) + the held-out UCI pixels; the threshold, the rule set and
  the relevance maximise the mean of the two IoUs (the adapted variant: the HGR photos' IoU alone,
  as single UCI pixels have no blob to adapt on).
* Test: the HGR photos of the remaining persons, the gtea_grasps frames (fraction of the true hand
  boxes' pixels marked skin, fraction of skin pixels outside the boxes, hands found: the k largest
  blobs (k the frame's true hands) matched to the true boxes at box IoU >= 0.5), and a contact sheet
  of the reach clip (no truth), with the static-background rule (`hog_jax.static_skin`, the clip's
  per-pixel temporal median as the background).

Per-pixel parts run in JAX on images edge-padded to one canvas (one compilation); the median filter
(`cv2.medianBlur`, replicated borders as `hog_jax.median3`) and components run in OpenCV per image.
"""
from __future__ import annotations

import itertools
import time
from pathlib import Path
from typing import NamedTuple

import cv2
import jax
import jax.numpy as jnp
import numpy as np

from experiments.data.hand_photos import REACH_CLIP, hgr_names, hgr_split, load_gtea, load_photo, scaled
from experiments.peers.ycrcb import ycrcb_rule
from hog_jax import (SkinRules, adapt_to_skin, fit_skin_model, fit_skin_rules, skin_log_ratio, skin_rule_mask,
                     static_skin)
from lfd_jax import UCI_FILE, iter_video, load_mask_pixels, load_uci_pixels

VARIANTS = ("ycrcb", "generic", "rules", "adapted")
ADAPT_PIXELS = 4096  # the most pixels of a confident blob the adaptation uses (a random sample)
RULE_NAMES = ("luma", "saturation", "texture")


class Setting(NamedTuple):
    """One way of marking skin: the model, the threshold, the rules (None: off), the relevance of the
    adaptation (None: off) and the margin above the threshold of the confident blob."""

    model: object
    threshold: float
    rules: SkinRules | None = None
    relevance: float | None = None
    margin: float = 2.0


def median_filtered(mask: np.ndarray, passes: int = 3) -> np.ndarray:
    """The 3 x 3 median filter `passes` times (cv2.medianBlur, replicated borders) of a bool mask."""
    m = mask.astype(np.uint8) * 255
    for _ in range(passes):
        m = cv2.medianBlur(m, 3)
    return m > 0


def _canvas(images: list[np.ndarray]) -> tuple[int, int]:
    return tuple(int(v) for v in np.max([im.shape[:2] for im in images], axis=0))


def _pad(im: np.ndarray, shape) -> np.ndarray:
    h, w = im.shape[:2]
    return np.pad(im, ((0, shape[0] - h), (0, shape[1] - w), (0, 0)), mode="edge")


def per_pixel(images: list[np.ndarray], fn, batch: int = 4) -> list[np.ndarray]:
    """fn((B, H, W, 3) float32) -> (B, H, W) over images padded to one canvas, cropped back."""
    shape = _canvas(images)
    out = []
    for start in range(0, len(images), batch):
        chunk = images[start:start + batch]
        padded = np.stack([_pad(im, shape) for im in chunk + [chunk[-1]] * (batch - len(chunk))])
        res = np.asarray(fn(padded))
        out += [res[i, :im.shape[0], :im.shape[1]] for i, im in enumerate(chunk)]
    return out


def largest_component(mask: np.ndarray) -> np.ndarray:
    """The largest 8-connected component of a bool mask (all False when it is empty)."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if n <= 1:
        return np.zeros_like(mask)
    return labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))


def confident_blob(ratio: np.ndarray, allowed: np.ndarray, threshold: float, margin: float) -> np.ndarray:
    """The person's skin sample of one image: the largest component of (ratio > threshold + margin)
    within the rules, median filtered, eroded by 2 px (away from its edges)."""
    blob = largest_component(median_filtered((ratio > threshold + margin) & allowed))
    return cv2.erode(blob.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0


class Ratios(NamedTuple):
    """Per image: the generic log ratio and where the rules allow skin (all True without rules)."""

    ratio: list
    allowed: list


def ratios(images, model, rules: SkinRules | None) -> Ratios:
    ratio = per_pixel(images, lambda x: skin_log_ratio(model, x))
    allowed = (per_pixel(images, lambda x: skin_rule_mask(rules, x)) if rules is not None
               else [np.ones(r.shape, bool) for r in ratio])
    return Ratios(ratio, allowed)


def adapted_ratio(image: np.ndarray, r: np.ndarray, allowed: np.ndarray, s: Setting, shape,
                  rng: np.random.Generator) -> np.ndarray:
    """The log ratio of one image under the model adapted to its confident blob (at most ADAPT_PIXELS
    of its pixels, drawn at random; unchanged when the blob has fewer than 50 pixels). The image is
    edge-padded to `shape` so that every image shares one compilation."""
    blob = confident_blob(r, allowed, s.threshold, s.margin)
    if blob.sum() < 50:
        return r
    pixels = image[blob]
    if len(pixels) > ADAPT_PIXELS:
        pixels = pixels[rng.choice(len(pixels), ADAPT_PIXELS, replace=False)]
    model = adapt_to_skin(s.model, pixels, relevance=s.relevance)
    h, w = image.shape[:2]
    return np.asarray(skin_log_ratio(model, _pad(image, shape)[None]))[0, :h, :w]


def skin_masks(images, s: Setting, base: Ratios | None = None, thresholds=None) -> list:
    """The filtered skin masks of `images` under setting `s` (at every threshold of `thresholds`
    when given: a list per threshold)."""
    base = base if base is not None else ratios(images, s.model, s.rules)
    rs = base.ratio
    if s.relevance is not None:
        shape, rng = _canvas(images), np.random.default_rng(0)
        rs = [adapted_ratio(im, r, a, s, shape, rng) for im, r, a in zip(images, base.ratio, base.allowed)]
    ts = [s.threshold] if thresholds is None else thresholds
    out = [[median_filtered((r > t) & a) for r, a in zip(rs, base.allowed)] for t in ts]
    return out[0] if thresholds is None else out


_ycrcb = jax.jit(lambda x: ycrcb_rule(jnp.round(x)))


def ycrcb_masks(images) -> list:
    """The YCrCb rule's masks (Chai & Ngan 1999, `experiments.peers.ycrcb.ycrcb_rule`), median filtered as ours."""
    return [median_filtered(m) for m in per_pixel(images, _ycrcb)]


def pooled_iou(masks, truths) -> float:
    tp = sum(int((m & t).sum()) for m, t in zip(masks, truths))
    union = sum(int((m | t).sum()) for m, t in zip(masks, truths))
    return tp / max(union, 1)


def photo_scores(masks, truths, min_iou: float = 0.5) -> dict:
    """Pooled IoU, mean per-photo IoU and the rate of photos whose largest component is the hand."""
    per = [pooled_iou([m], [t]) for m, t in zip(masks, truths)]
    found = [pooled_iou([largest_component(m)], [t]) >= min_iou for m, t in zip(masks, truths)]
    return {"iou": pooled_iou(masks, truths), "iou_per_photo_mean": float(np.mean(per)),
            "hand_found_rate": float(np.mean(found))}


def pixel_iou(pred: np.ndarray, truth: np.ndarray) -> float:
    return float((pred & truth).sum() / max((pred | truth).sum(), 1))


def box_iou(a, b) -> float:
    """IoU of (top, left, bottom, right) boxes, bottom / right exclusive."""
    h = max(0, min(a[2], b[2]) - max(a[0], b[0]))
    w = max(0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = h * w
    area = lambda r: (r[2] - r[0]) * (r[3] - r[1])
    return inter / max(area(a) + area(b) - inter, 1)


def blob_boxes(mask: np.ndarray, k: int) -> list:
    """The (top, left, bottom, right) boxes of the k largest 8-connected components."""
    n, _, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    order = 1 + np.argsort(-stats[1:, cv2.CC_STAT_AREA])[:k]
    return [(stats[i, 1], stats[i, 0], stats[i, 1] + stats[i, 3], stats[i, 0] + stats[i, 2]) for i in order]


def hands_found(mask: np.ndarray, boxes: np.ndarray, min_iou: float = 0.5) -> int:
    """True hand boxes matched (greedily, best IoU first) by the k largest blobs' boxes at IoU >= min_iou."""
    cand = blob_boxes(mask, len(boxes))
    pairs = sorted(((box_iou(c, b), i, j) for i, c in enumerate(cand) for j, b in enumerate(boxes)), reverse=True)
    used_c, used_b, found = set(), set(), 0
    for iou, i, j in pairs:
        if iou >= min_iou and i not in used_c and j not in used_b:
            used_c.add(i), used_b.add(j)
            found += 1
    return found


def gtea_scores(masks, frames) -> dict:
    """Fraction of the true hand boxes' pixels marked skin, fraction of the marked pixels outside
    them, and the rate of hands found; the drawn annotation is left out of every count (a mask
    touching it is cut there before the blobs)."""
    inside = total_in = outside = total = found = hands = 0
    for m, f in zip(masks, frames):
        m = m & ~f.ignore
        inside += int((m & f.in_box).sum())
        total_in += int((f.in_box & ~f.ignore).sum())
        outside += int((m & ~f.in_box).sum())
        total += int(m.sum())
        found += hands_found(m, f.boxes)
        hands += len(f.boxes)
    return {"in_box_skin": inside / max(total_in, 1), "skin_outside_boxes": outside / max(total, 1),
            "hands_found_rate": found / max(hands, 1), "n_hands": hands}


# --- fitting and choosing --------------------------------------------------------------------------------

class Fitted(NamedTuple):
    model: object                 # the chosen colour space's model (`choose_space`)
    models: dict                  # colour space -> model
    rules_all: SkinRules          # every rule fitted (the validation chooses which are on)
    uci_val_rgb: np.ndarray
    uci_val_skin: np.ndarray
    n_fit: dict


def _photos(cfg, names):
    out = []
    for name in names:
        p = load_photo(cfg.data, name)
        rgb, truth = scaled(p.bgr[..., ::-1].astype(np.float32), cfg.photo_scale, (p.truth,))
        out.append((name, rgb, truth))
    return out


def fit_stage(cfg, split) -> Fitted:
    """The model fitted on UCI (fitting part) and the fitting persons' HGR pixels; rule bounds learnt
    from the fitting photos' true skin."""
    rng = np.random.default_rng(cfg.seed)
    rgb, is_skin = load_uci_pixels(Path(cfg.data) / UCI_FILE)
    order = rng.permutation(len(rgb))
    n_val = int(round(cfg.validation_fraction * len(rgb)))
    val, fit = order[:n_val], order[n_val:]
    val = val[:cfg.uci_validation_pixels]
    half = cfg.fit_pixels // 2
    fit_skin = rng.choice(fit[is_skin[fit]], half, replace=False)
    fit_bg = rng.choice(fit[~is_skin[fit]], half, replace=False)
    skin, background = [rgb[fit_skin]], [rgb[fit_bg]]
    n_fit = {"uci_skin": half, "uci_non_skin": half}
    if cfg.fit_sources == "uci+hgr":
        folder = Path(cfg.data) / "hgr_hands"
        hrgb, hskin = load_mask_pixels([folder / "images" / f"{n}.jpg" for n in split["fit"]],
                                       [folder / "masks" / f"{n}.bmp" for n in split["fit"]], cfg.fit_pixels, cfg.seed)
        skin.append(hrgb[hskin])
        background.append(hrgb[~hskin])
        n_fit.update(hgr_skin=int(hskin.sum()), hgr_non_skin=int((~hskin).sum()), hgr_photos=len(split["fit"]))
    models = {space: fit_skin_model(jax.random.key(cfg.seed), np.concatenate(skin), np.concatenate(background),
                                    n_components=cfg.n_components, n_background=cfg.n_background, n_iter=cfg.n_iter,
                                    luma=space == "crcby")
              for space in cfg.colour_spaces}
    photos = _photos(cfg, split["fit"][::max(1, len(split["fit"]) // cfg.rule_photos)])
    shape = _canvas([p[1] for p in photos])
    frames = np.stack([_pad(p[1], shape) for p in photos])
    truth = np.stack([np.pad(p[2], ((0, shape[0] - p[2].shape[0]), (0, shape[1] - p[2].shape[1]))) for p in photos])
    if cfg.texture_erode:  # the texture bound from the skin's inside, away from the hand's outline
        k = np.ones((2 * cfg.texture_erode + 1,) * 2, np.uint8)
        truth = np.stack([cv2.erode(t.astype(np.uint8), k) > 0 for t in truth])
    texture = fit_skin_rules(frames, truth, ("texture",), cfg.rule_quantile, cfg.texture_window)
    all_skin = np.concatenate(skin)  # luma and saturation from every fitted skin pixel (UCI faces and HGR hands)
    colour = fit_skin_rules(all_skin[:, None, None, :], np.ones((len(all_skin), 1, 1), bool), ("luma", "saturation"),
                            cfg.rule_quantile, cfg.texture_window)
    first = models[cfg.colour_spaces[0]]
    return Fitted(first, models, colour._replace(max_texture=texture.max_texture), rgb[val], is_skin[val], n_fit)


def _rules_subset(rules: SkinRules, names) -> SkinRules | None:
    if not names:
        return None
    off = SkinRules(window=rules.window)
    return SkinRules(min_luma=rules.min_luma if "luma" in names else off.min_luma,
                     max_luma=rules.max_luma if "luma" in names else off.max_luma,
                     max_saturation=rules.max_saturation if "saturation" in names else off.max_saturation,
                     max_texture=rules.max_texture if "texture" in names else off.max_texture, window=rules.window)


def _uci_ious(fitted: Fitted, rules: SkinRules | None, thresholds, model=None) -> np.ndarray:
    """IoU of the held-out UCI pixels at each threshold (luma and saturation rules apply per pixel; the
    texture rule needs neighbours and passes every single pixel)."""
    x = fitted.uci_val_rgb
    r = np.asarray(skin_log_ratio(fitted.model if model is None else model, x))
    allowed = np.ones(len(x), bool)
    if rules is not None:
        per_pixel_rules = rules._replace(max_texture=np.inf)
        allowed = np.asarray(skin_rule_mask(per_pixel_rules, x[None, :, None, :]))[0, :, 0]
    return np.array([pixel_iou((r > t) & allowed, fitted.uci_val_skin) for t in thresholds])


def choose_space(cfg, fitted: Fitted, val_photos) -> tuple[Fitted, dict]:
    """The colour space whose generic model has the best validation score (mean of the HGR validation
    photos' IoU and the held-out UCI pixels' IoU at its best threshold)."""
    images, truths = [p[1] for p in val_photos], [p[2] for p in val_photos]
    ts = list(cfg.thresholds)
    table = {}
    for space, model in fitted.models.items():
        hgr = np.array([pooled_iou(m, truths) for m in skin_masks(images, Setting(model, 0.0), None, ts)])
        score = 0.5 * (hgr + _uci_ious(fitted, None, ts, model))
        i = int(np.argmax(score))
        table[space] = {"threshold": ts[i], "score": float(score[i]), "hgr_iou": float(hgr[i])}
    chosen = max(table, key=lambda k: table[k]["score"])
    return fitted._replace(model=fitted.models[chosen]), {"spaces": table, "space_chosen": chosen}


def choose_stage(cfg, fitted: Fitted, val_photos) -> tuple[dict, dict]:
    """(settings per variant, validation metrics): threshold, rules, relevance chosen on validation."""
    images, truths = [p[1] for p in val_photos], [p[2] for p in val_photos]
    ts = list(cfg.thresholds)
    table, best = {}, {}
    for names in itertools.chain.from_iterable(itertools.combinations(RULE_NAMES, k) for k in range(4)):
        rules = _rules_subset(fitted.rules_all, names)
        base = ratios(images, fitted.model, rules)
        hgr = np.array([pooled_iou(m, truths) for m in skin_masks(images, Setting(fitted.model, 0.0, rules), base, ts)])
        uci = _uci_ious(fitted, rules, ts)
        score = 0.5 * (hgr + uci)
        i = int(np.argmax(score))
        key = "+".join(names) or "none"
        table[key] = {"threshold": ts[i], "score": float(score[i]), "hgr_iou": float(hgr[i]), "uci_iou": float(uci[i])}
        best[key] = (score[i], ts[i], rules, base)
    generic_key = "none"
    rules_key = max((k for k in table if k != "none"), key=lambda k: table[k]["score"])
    settings = {"generic": Setting(fitted.model, best[generic_key][1]),
                "rules": Setting(fitted.model, best[rules_key][1], best[rules_key][2])}
    # adaptation on top of the better of the two (the HGR validation photos' IoU alone)
    on = "rules" if table[rules_key]["score"] > table[generic_key]["score"] else "generic"
    base_key = rules_key if on == "rules" else generic_key
    adapt_table = {}
    for relevance in cfg.relevances:
        s = settings[on]._replace(relevance=float(relevance), margin=cfg.adapt_margin)
        hgr = np.array([pooled_iou(m, truths) for m in skin_masks(images, s, best[base_key][3], ts)])
        i = int(np.argmax(hgr))
        adapt_table[f"{relevance:g}"] = {"threshold": ts[i], "hgr_iou": float(hgr[i])}
    top = max(r["hgr_iou"] for r in adapt_table.values())
    # within the tolerance of the best, the largest relevance (the smallest step from the generic model)
    r_best = max((k for k, r in adapt_table.items() if r["hgr_iou"] >= top - cfg.relevance_tolerance), key=float)
    settings["adapted"] = settings[on]._replace(relevance=float(r_best), threshold=adapt_table[r_best]["threshold"],
                                                margin=cfg.adapt_margin)
    y = ycrcb_masks(images)
    metrics = {"rule_sets": table, "rules_chosen": rules_key, "adapted_on": on, "relevance": adapt_table,
               "relevance_chosen": float(r_best), "hgr_iou_ycrcb": pooled_iou(y, truths)}
    return settings, metrics


# --- the reach clip ------------------------------------------------------------------------------------

def mask_sheet(images, titles, masks: dict, title: str):
    """A contact sheet: one row per image (the image, then each method's mask in green with the
    share of the image it marks)."""
    import matplotlib.pyplot as plt
    cols = 1 + len(masks)
    fig, axes = plt.subplots(len(images), cols, figsize=(2.2 * cols, 2.1 * len(images)), squeeze=False)
    for k, (row, im) in enumerate(zip(axes, images)):
        row[0].imshow(np.clip(im, 0, 255).astype(np.uint8))
        row[0].set_title(titles[k], fontsize=7)
        for ax, (name, ms) in zip(row[1:], masks.items()):
            view = 0.4 * np.clip(im, 0, 255) / 255.0
            view[ms[k]] = 0.3 * view[ms[k]] + 0.7 * np.array([0.1, 0.9, 0.1])
            ax.imshow(view)
            ax.set_title(f"{name}: {100 * ms[k].mean():.1f} %", fontsize=7)
    for ax in axes.flat:
        ax.axis("off")
    fig.suptitle(title, fontsize=8)
    fig.tight_layout()
    return fig


def reach_sheet(cfg, settings: dict):
    """The reach clip's contact sheet (no truth): evenly spaced frames, each variant's mask and the
    static-background rule on the rules variant; (None, {}) when the clip is absent."""
    path = Path(cfg.data) / REACH_CLIP
    if not path.is_file():
        return None, {}
    frames = np.concatenate(list(iter_video(path))).astype(np.float32)
    background = np.median(frames, axis=0)
    picks = np.linspace(0, len(frames) - 1, cfg.reach_sheet_frames).round().astype(int)
    images = [frames[i] for i in picks]
    masks = {"ycrcb": ycrcb_masks(images)}
    for v in ("generic", "rules", "adapted"):
        masks[v] = skin_masks(images, settings[v])
    s = settings["rules"]
    static = np.asarray(static_skin(s.model, np.stack(images), background, threshold=s.threshold,
                                    max_difference=cfg.static_difference))
    masks["rules + static"] = [m & ~st for m, st in zip(masks["rules"], static)]
    fig = mask_sheet(images, [f"frame {i}" for i in picks], masks,
                     "reach clip (no truth): skin in green, % of the frame marked")
    fractions = {name: float(np.mean([m.mean() for m in ms])) for name, ms in masks.items()}
    return fig, fractions


def run_one_model(cfg) -> tuple[dict, dict, dict]:
    """(metrics, figures, settings) of the whole study."""
    t0 = time.perf_counter()
    split = hgr_split(hgr_names(cfg.data), tuple(cfg.hgr_fit_ids), tuple(cfg.hgr_validation_ids))
    if cfg.n_photos:
        split = {k: v[::max(1, len(v) // cfg.n_photos)][:cfg.n_photos] if k != "fit" else v for k, v in split.items()}
    fitted = fit_stage(cfg, split)
    fit_s = time.perf_counter() - t0
    val_photos = [(name, np.clip(rgb * e, 0, 255), truth) for e in cfg.validation_exposures
                  for name, rgb, truth in _photos(cfg, split["validation"])]  # other light: exposure-scaled copies
    fitted, spaces = choose_space(cfg, fitted, val_photos)
    settings, chosen = choose_stage(cfg, fitted, val_photos)
    chosen.update(spaces)
    choose_s = time.perf_counter() - t0 - fit_s
    metrics: dict = {"n_fit": fitted.n_fit, "split": {k: len(v) for k, v in split.items()}, "validation": chosen,
                     "rules_fitted": fitted.rules_all._asdict(),
                     "settings": {v: {"threshold": s.threshold, "rules": None if s.rules is None else s.rules._asdict(),
                                      "relevance": s.relevance} for v, s in settings.items()},
                     "fit_s": fit_s, "choose_s": choose_s}
    test = _photos(cfg, split["test"])
    images, truths = [p[1] for p in test], [p[2] for p in test]
    hgr = {"ycrcb": photo_scores(ycrcb_masks(images), truths)}
    for v in ("generic", "rules", "adapted"):
        hgr[v] = photo_scores(skin_masks(images, settings[v]), truths)
    others = {space: Setting(model, spaces["spaces"][space]["threshold"]) for space, model in fitted.models.items()
              if space != spaces["space_chosen"]}  # the generic model of each space not chosen, for the record
    for space, s in others.items():
        hgr[f"generic_{space}"] = photo_scores(skin_masks(images, s), truths)
    metrics["hgr_test"] = hgr
    gtea_dir, figures_gtea = Path(cfg.data) / "gtea_grasps", None
    if gtea_dir.is_dir():
        frames = load_gtea(cfg.data, cfg.gtea_scale)[:cfg.gtea_frames or None]
        ims = [f.rgb for f in frames]
        sheet_masks = {"ycrcb": ycrcb_masks(ims)}
        gtea = {"ycrcb": gtea_scores(sheet_masks["ycrcb"], frames)}
        for v in ("generic", "rules", "adapted"):
            sheet_masks[v] = skin_masks(ims, settings[v])
            gtea[v] = gtea_scores(sheet_masks[v], frames)
        for space, s in others.items():
            gtea[f"generic_{space}"] = gtea_scores(skin_masks(ims, s), frames)
        metrics["gtea"] = gtea
        picks = np.linspace(0, len(frames) - 1, min(cfg.reach_sheet_frames, len(frames))).round().astype(int)
        figures_gtea = mask_sheet([ims[i] for i in picks], [frames[i].name for i in picks],
                                  {k: [v[i] for i in picks] for k, v in sheet_masks.items()},
                                  "gtea_grasps: skin in green (annotation pixels not masked here)")
    fig, fractions = reach_sheet(cfg, settings)
    figures = {} if fig is None else {"reach_sheet.png": fig}
    if figures_gtea is not None:
        figures["gtea_sheet.png"] = figures_gtea
    metrics["reach_skin_fraction"] = fractions
    metrics["total_s"] = time.perf_counter() - t0
    return metrics, figures, settings
