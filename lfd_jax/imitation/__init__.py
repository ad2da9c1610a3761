"""lfd_jax.imitation: from a demonstration video to the robot's task.

The pipeline of LFD (Kjellström & Kragic 2009) with the PHMMs of Herzog et al. 2008 and the grasp
mapping of MAP (Romero et al. 2009), step by step:

1. The video front end (`hog_jax.video`) tracks the hand relative to the face in both views; its
   output for one recording is a `Tracked` (hand - face in world axes, turned by `camera_rotation`).
2. The tracked stream is cleaned (`plausible`, `median_filter`, `stream_of`) and the online PHMM
   recogniser (`recognizer`, `movement`; PHMM BMVC §5.4) finds the movement, its class (`KINDS`:
   point or transfer) and its target on the table (`TableArea`, `phi_to_xy`, `xy_to_phi`); a pointing's
   object is the one at whose parameter the PHMM finds the movement likeliest (`likeliest_object`).
3. The grasp moment and the put-down come from the hand's speed (`grasp_and_putdown`); a transfer's
   target from its reach alone (`reach_segment`, `reach_target`); which object moved and where it was
   put, from the scene at rest before and after the movement (`place_reader`, `scene_place`,
   `ScenePlace`, `moved_object`, `changed_shares`, `pixel_ray`, `project`).
4. `recognise_demo` runs 2-3 on one tracked recording -> `Recognised`.
5. The robot repeats the task (`task_spec`, `robot_task`; MAP §III), approaching along the reach
   PHMM's synthesised movement (`synthesised_reach`), the hand turned as the person's was where the
   grasp recogniser gave an orientation (`hand_rotation`).

Example:
    ```python
    from lfd_jax import imitation as im
    online = im.recognizer(phmms, sigma_m=0.1, threshold_m=0.08, window=3)
    r = im.recognise_demo(online, tracked, offset, median_frames=3, objects_xy=objects_xy,
                          handover_xy=(-0.1, -0.3))
    result = im.robot_task(r, objects=(3, 7, 11), objects_xy=objects_xy)
    ```
"""
from lfd_jax.imitation._src.area import TableArea, phi_to_xy, xy_to_phi
from lfd_jax.imitation._src.place import (ScenePlace, changed_shares, moved_object, pixel_ray, place_reader, project,
                                          scene_place)
from lfd_jax.imitation._src.recognition import (KINDS, Recognised, grasp_and_putdown, likeliest_object, movement,
                                                reach_segment, reach_target, recognise_demo, recognizer)
from lfd_jax.imitation._src.robot import hand_rotation, robot_task, synthesised_reach, task_spec
from lfd_jax.imitation._src.tracked import Tracked, camera_rotation, median_filter, plausible, stream_of

__all__ = [
    "KINDS", "Recognised", "ScenePlace", "TableArea", "Tracked", "camera_rotation", "changed_shares",
    "grasp_and_putdown", "hand_rotation", "likeliest_object", "median_filter", "moved_object", "movement", "phi_to_xy",
    "pixel_ray", "place_reader", "plausible", "project", "reach_segment", "reach_target", "recognise_demo",
    "recognizer", "robot_task", "scene_place", "stream_of", "synthesised_reach", "task_spec", "xy_to_phi",
]
