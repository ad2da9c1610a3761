"""The study's recogniser: `lfd_jax.grasp.build_recogniser` with the options of a `Config`, the view
database of a `Config` (`experiments.data.grasp_database.database`), and the scene convnet
(cfg.classifier "scene_cnn"), trained on rendered scenes segmented as the queries are."""
from __future__ import annotations

import dataclasses

from experiments.config import progress
from experiments.data.grasp_database import DatabaseOptions, database, randomized_scenes
from experiments.grasp_recognition.config import Config
from experiments.grasp_recognition.scene_realism import realism_of, scene_patches, usable_steps
from lfd_jax.grasp import (ConvClassifier, Crops, Recogniser, RecogniserOptions, build_recogniser, cached_convnet,
                           fit_convnet, realistic_frames, segment_frames)
from sim.grasping import GRASP_CLASSES

# what the scene convnet's training runs besides `lfd_jax.grasp`: this study's `train` below, the scene
# renderer (`sim`, the grasp sets) and the segmentation (`hog_jax`)
SCENE_NET_PACKAGES = ("experiments.grasp_recognition", "experiments.data.grasp_database",
                      "experiments.data.grasp_tests", "hog_jax")


def _fields(cls, cfg: Config) -> dict:
    return {f.name: getattr(cfg, f.name) for f in dataclasses.fields(cls)}


def recogniser_options(cfg: Config) -> RecogniserOptions:
    """The `lfd_jax.grasp.RecogniserOptions` of a configuration (its fields of the same names)."""
    return RecogniserOptions(**_fields(RecogniserOptions, cfg))


def database_options(cfg: Config) -> DatabaseOptions:
    """The `experiments.data.grasp_database.DatabaseOptions` of a configuration."""
    return DatabaseOptions(**_fields(DatabaseOptions, cfg))


def study_database(cfg: Config):
    """The view database of a configuration (`grasp_database.database`)."""
    return database(database_options(cfg), progress=lambda it, total, d: progress(it, desc=d, total=total))


def trained_scene_convnet(cfg: Config, skin) -> ConvClassifier:
    """The convnet on the unmasked boxes around the hand (`lfd_jax.grasp.fit_convnet`, context input),
    trained on `cfg.n_scenes` rendered scenes per grasp (`randomized_scenes`, `cfg.n_scene_hands` hands
    each) through the realism steps of `cfg.scene_realism` (`scene_realism.realism_of`: background
    patches from `cfg.backgrounds` in a share `cfg.background_share` of the scenes, light, blur, noise,
    JPEG; `scene_realism.usable_steps`) and segmented by `skin` as the queries are
    (cfg.skin_adaptation); cached by the scenes' settings, the steps, the skin model's arrays and the
    training settings (the realism steps and the segmentation run only to train)."""
    steps = usable_steps(cfg.scene_realism, cfg.backgrounds)
    settings = dict(scenes=cfg.n_scenes, hands=cfg.n_scene_hands, frame=cfg.frame_size, skin=skin,
                    adaptation=cfg.skin_adaptation, crop=cfg.crop_size, seed=cfg.seed, width=cfg.cnn_width,
                    epochs=cfg.cnn_epochs, realism=steps, backgrounds=cfg.backgrounds,
                    background_share=cfg.background_share)

    def train():
        scenes = randomized_scenes(cfg.n_scenes, cfg.n_scene_hands, cfg.seed, cfg.frame_size,
                                   progress=lambda it, total, d: progress(it, desc=d, total=total))
        realism = realism_of(steps, cfg.background_share)
        patches = scene_patches(cfg.backgrounds, cfg.frame_size, cfg.seed) if realism.background else None
        frames = realistic_frames(scenes.frames, scenes.foreground, realism, patches, seed=cfg.seed)
        crops = segment_frames(skin, frames, cfg.crop_size, adaptation=cfg.skin_adaptation)
        c = crops.take(crops.found)
        return fit_convnet(c.images, c.masks, scenes.labels[crops.found], len(GRASP_CLASSES), cfg.seed, cfg.cnn_width,
                           cfg.cnn_epochs, progress=lambda it, total: progress(it, desc="train scene convnet",
                                                                               total=total), context=c.context)

    return cached_convnet(settings, train, context=True, packages=SCENE_NET_PACKAGES)


def recogniser_of(cfg: Config, key, db, tune_images: Crops | None, skin=None) -> Recogniser:
    """`lfd_jax.grasp.build_recogniser` with cfg's options on the database `db`, LSH tuned on
    `tune_images` (None: no index); `skin`: the skin model that segments the queries, which the scene
    convnet (cfg.classifier "scene_cnn") segments its training scenes with."""
    net = None
    if cfg.classifier == "scene_cnn":
        if skin is None:
            raise ValueError("skin: the scene convnet needs the skin model that segments the queries")
        net = trained_scene_convnet(cfg, skin)
    return build_recogniser(recogniser_options(cfg), key, db, tune_images, net)
