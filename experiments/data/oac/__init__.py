"""Simulated OAC recordings (ECCV 2008 §5, LfD 2009 §V): three object-action complexes performed by
10 persons x 5 repetitions, seen by a small-baseline stereo camera.

Classes (action, object, the grasp of `sim.grasp_objects` the hand takes):
    0 look through binoculars   (grasp 1, Large Diameter around the right barrel)
    1 drink from cup            (grasp 4, Abducted Thumb around the cup body; or, for about 3 persons
                                 in 10, grasp 2, Small Diameter around the cup's handle)
    2 pour from pitcher         (grasp 2, Small Diameter around the handle)
Two actions look alike in hand position ("look through" and "drink from" both bring the hand to the
face; the hand centroid differs by a few centimetres, less than persons differ) and two objects look
alike (cup and pitcher: same white ceramic, a cylinder with a handle; after the square-normalised,
one-level object HOG of §5 their size difference is gone).

A recording is pre-segmented (pick-up to put-down): the grasped object is lifted from the table,
brought to the action's target (eyes / mouth / above a glass at chest height), the action is
performed (scanning with the binoculars, tilting the cup towards the face, tilting the pitcher to
pour), and the object is put back. Minimum-jerk transport with a person-specific arc, timing, reach
amplitude, target offsets, hold time and tilt; repetition-to-repetition jitter on all of them.

Persons (7 men and 3 women, as the papers) differ in body size (which scales the face height, the
reach and the hand; the hand model is scaled with it), speed, amplitude and style (arc, target
offsets, tilt, wrist roll, whether they hold the cup by its handle). Cameras: a rectified stereo pair (baseline 12 cm, f = 525 px, 640 x 480)
1.4-1.8 m in front of the person, its pose jittered per person.

Per frame t (T frames at `fps`, padded to the longest sequence, `lengths` gives the true ones):
    pos2d (2,)  hand-mask centroid minus face-mask centroid in the left image, pixels (x right, y down)
    pos3d (3,)  the same two centroids triangulated from left and right image, metres, camera frame
    hand_hog    HOG (B = 4, L = `hand_levels`) of the segmented hand image: the human hand model of
                `sim.human_hand` (scaled to the person) in the object's grasp (`sim.human_grasps`),
                rendered with MuJoCo from the camera's view; the mask is what skin segmentation
                gives (hand pixels, plus the face's when the two touch in the image; the object in
                front occludes the hand), with a one-pixel boundary error (erosion / dilation) and
                motion blur over the exposure; cropped to the mask's bounding square, grey levels
                with camera noise
    object_hog  HOG (B = 4, L = `object_levels`, 1 as in §5) of the object window: a fixed window,
                placed relative to the hand and shaped to the object's bounding box in the first
                frame (as ECCV §3), rescaled to a square (§5), object pixels only (the hand occludes)
Centroid measurement noise is what skin segmentation gives: a slowly varying (AR(1)) offset of a few
pixels per blob, larger when the hand blob touches the face blob (the papers separate merged blobs
with an alpha-beta filter). Most of that error is common to the left and right image; the 1 px
that is not makes the stereo depth noisy (about 6 cm per blob at 1.6 m), as LfD Fig. 7b shows.

Rendering: two small views per frame (hand, object window), each an RGB and a segmentation pass of
MuJoCo's offscreen renderer (shadows off), at `image_px` square, aimed from the left camera at the
hand / the object window (about 20 ms per frame on a 2-core CPU; every frame at `fps` is rendered);
the generated set is cached under `lfd_common.cache_dir("oac")` keyed by every setting. `generate(OACSettings(...))` -> `OACData`.
"""
from __future__ import annotations

from experiments.data.oac.settings import (ACTIONS, BASELINE_M, CLASSES, FOCAL_PX, IMAGE_SIZE_PX, N_CLASSES, OACData,
                                           OACSettings, OBJECTS, Person, TABLE_Z_M, draw_persons)
from experiments.data.oac.motion import camera_pose, measured_positions, object_trajectory, project, triangulate
from experiments.data.oac.grips import grip_of
from experiments.data.oac.scene import scene_xml
from experiments.data.oac.views import masked_hog, record, skin_segment
from experiments.data.oac.generate import generate, recording_images

__all__ = ["ACTIONS", "BASELINE_M", "CLASSES", "FOCAL_PX", "IMAGE_SIZE_PX", "N_CLASSES", "OACData", "OACSettings",
           "OBJECTS", "Person", "TABLE_Z_M", "camera_pose", "draw_persons", "generate", "grip_of", "masked_hog",
           "measured_positions", "object_trajectory", "project", "record", "recording_images", "scene_xml",
           "skin_segment", "triangulate"]
