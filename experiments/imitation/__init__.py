"""The imitation loop: from a demonstration video to what the robot must do.

    python -m experiments.imitation --preset quick|paper --out DIR

Demonstrations (`demonstrations`): a person at the table with the three OAC objects at random places
points at one (the robot must fetch it to a hand-over spot in front of the person) or picks one up with
one of the six grasps of GRASP §II and puts it at a new place (the robot repeats the transfer);
rendered by `experiments.data.video` (LfD 2009 §III-A, §V), random persons, objects' places, grasps.

Per demonstration (`stages.run_demo`, `pipeline`, the steps of `lfd_jax.imitation`):
1. video -> the stereo video front end (LEVELSET TR §3, LfD 2009 §III-C: level sets, α-β tracks of
   both views, the triangulated hand relative to the face);
2. the online PHMM recogniser (BMVC 2008 §5.4: a streaming forward state per class, movement start
   and end detected, class and parameter after a latency of `online_window_s`; Humanoids 2008
   §III): point or pick-and-place, and the target on the table, snapped to the nearest object; a
   movement called a pointing is a pick-and-place where the video shows an object moved
   (`lfd_jax.imitation.place_reader`);
3. the grasp moment and the put-down from the hand's speed along the movement; the place = where the
   object stood plus its own displacement between the scene at rest before and after the movement
   (`lfd_jax.imitation.scene_place`), or, where the video does not show it, plus the hand's
   displacement between them;
4. the grasp class from the hand image at the grasp moment (`grasp_stage`; GRASP §III, eq. 3: HOG, kNN
   over hand crops of demonstrations of their own seed, or a convnet trained on them, or kNN over the
   grasp study's rendered database, which also gives the hand's orientation, eq. 4); the hand cut from
   the left view or from a foveal camera turned to the tracked hand (`fovea`);
5. the robot (`sim.task_controller.run_task`, MAP §III grasp strategy with the mapped preshape) does
   the task, its hand turned about the vertical as the person's where eq. 4 gave an orientation and
   `robot_orientation` is "recognised" (else the grasp's canonical orientation).
Settings (tracker offset, PHMM observation noise, movement threshold) are chosen on validation
demonstrations of their own seed; the PHMMs are trained on kinematics of a third seed.

Outputs: metrics.json (`n_demonstrations`, `action_accuracy`, `target_error_cm`, `grasp_accuracy`,
`task_success_rate`: the demonstrated object within 5 cm of the demonstrated place, upright, whatever
grasp the robot used; `task_success_all_recognised_rate`: that and everything recognised right;
`task_success_undisturbed_rate`: that and no other object pushed more than 5 cm (the arm has no
collision-aware path; `others_disturbed_rate`);
`failures_by_stage`, `runtime_s`, per-stage times, ...), report.md,
side_by_side.mp4 (the person | the robot, or the recognised scene where no robot ran).

API: `Config`, `PRESETS`, `Demo`, `draw_demos`, `render_demo`, `prepare` (the models), `run_demo`,
`summarise`, `main`.
"""
from experiments.imitation.config import PRESETS, Config
from experiments.imitation.demonstrations import Demo, draw_demos, render_demo
from experiments.imitation.stages import prepare, run_demo, summarise, main

__all__ = ["Config", "Demo", "PRESETS", "draw_demos", "main", "prepare", "render_demo", "run_demo", "summarise"]
