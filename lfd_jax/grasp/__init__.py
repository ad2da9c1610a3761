"""lfd_jax.grasp: the grasp class and hand orientation from one image of a grasping hand.

GRASP (Kjellström, Romero & Kragic, IROS 2008), step by step:

1. The hand is skin-segmented and cropped (§III-A): `segment_frames` -> `Crops` (grey crop times the
   hand mask, the mask, whether a hand was found, the unmasked box); `crops_of` converts a
   `hog_jax.Segmentation`.
2. Each crop becomes a HOG pyramid (§IV, eq. 1): `hog_features`.
3. A view database (rendered hand views labelled with grasp class and orientation, e.g.
   `sim.grasping.view_database`) becomes a `Recogniser` (`build_recogniser` with `RecogniserOptions`):
   the distance-weighted kNN model (§V, eqs. 3-5), an LSH index tuned for recall@k (§V, eq. 2),
   optionally a learned metric and a network that gives the class.
4. `recognise` gives the class (eq. 3) and orientation (eq. 4) of each query's `features`;
   `knn_predict` does the same for a bare `hog_jax.KNNModel`.

Beyond the paper, the class can come from a trained network, with eq. 4's orientation within that
class: a perceptron on HOG (`fit_classifier`, `classify`, `NetClassifier`) or a convnet on the crops
or on the unmasked boxes around the hand (`fit_convnet`, `classify_crops`, `network_input`,
`augment`, `ConvClassifier`; cached on disk by `cached_convnet`, `trained_convnet`); `net_labels`
gives a recogniser's network's classes. Rendered training frames can be made to look more like real
photos first (`realistic_frames` with `Realism`: real background texture `paste_backgrounds` from
`background_patches`, light `adjust_light`, `blur` with `gaussian_kernels` / `motion_kernels`,
`add_noise`, `jpeg_roundtrip`; parameters drawn by `sample_realism`).

Every public function raises `ValueError` naming the argument for inputs of the wrong shape, empty
where data is needed, or non-finite.

Example:
    ```python
    import jax
    import numpy as np
    from lfd_jax import grasp
    from sim.grasping import view_database

    db = view_database(n_azimuth=12, n_elevation=4)     # 48 rendered views of each grasp
    rec = grasp.build_recogniser(grasp.RecogniserOptions(k=5), jax.random.key(0), db)
    found = np.ones(3, bool)
    x = grasp.features(rec, db.images[:3], db.masks[:3], found)
    out = grasp.recognise(rec, x, found, exact=True)   # out.labels (3,), out.quat (3, 4)
    ```
"""
from lfd_jax.grasp._src.classifier import NetClassifier, classify, fit_classifier
from lfd_jax.grasp._src.convnet import (ConvClassifier, augment, cached_convnet, classify_crops, fit_convnet,
                                        network_input)
from lfd_jax.grasp._src.crops import Crops, crops_of, segment_frames
from lfd_jax.grasp._src.knn import hog_features, knn_predict
from lfd_jax.grasp._src.realism import (Realism, RealismParams, add_noise, adjust_light, background_patches, blur,
                                        gaussian_kernels, jpeg_roundtrip, motion_kernels, paste_backgrounds,
                                        realistic_frames, sample_realism)
from lfd_jax.grasp._src.recogniser import (Recognised, Recogniser, RecogniserOptions, build_recogniser, features,
                                           hog_config, net_labels, recognise, trained_convnet, transformed)

__all__ = [
    "ConvClassifier", "Crops", "NetClassifier", "Realism", "RealismParams", "Recognised", "Recogniser",
    "RecogniserOptions", "add_noise", "adjust_light", "augment", "background_patches", "blur", "build_recogniser",
    "cached_convnet", "classify", "classify_crops", "crops_of", "features", "fit_classifier", "fit_convnet",
    "gaussian_kernels", "hog_config", "hog_features", "jpeg_roundtrip", "knn_predict", "motion_kernels",
    "net_labels", "network_input", "paste_backgrounds", "realistic_frames", "recognise", "sample_realism",
    "segment_frames", "trained_convnet", "transformed",
]
