"""A transfer's place read from the object's own displacement in the video (`lfd_jax.imitation.place_reader`),
on a synthetic scene with a known camera: a box moved on a table, the lights 25 % brighter afterwards,
and a change of the person's posture beside it."""
import cv2
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from lfd_jax.imitation import moved_object, pixel_ray, place_reader, project, scene_place

TABLE_Z = 0.75
BOX = np.array([0.06, 0.06, 0.12])  # x, y, z extent (m) of the moved object


def _camera() -> np.ndarray:
    """A 320 x 240 camera in front of the table, looking down at it (world z up)."""
    centre, aim = np.array([0.0, 0.9, 1.25]), np.array([0.0, -0.35, TABLE_Z])
    forward = (aim - centre) / np.linalg.norm(aim - centre)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    R = np.stack([right, down, forward])
    K = np.array([[300.0, 0, 160], [0, 300.0, 120], [0, 0, 1]])
    return K @ np.c_[R, -R @ centre]


def _draw_box(img: np.ndarray, P: np.ndarray, xy, colour, size=BOX) -> None:
    corners = [np.r_[xy[0] + sx * size[0] / 2, xy[1] + sy * size[1] / 2, TABLE_Z + sz * size[2]]
               for sx in (-1, 1) for sy in (-1, 1) for sz in (0, 1)]
    hull = cv2.convexHull(np.round([project(P, c) for c in corners]).astype(np.int32))
    cv2.fillConvexPoly(img, hull, colour)


STILL_XY = (-0.05, -0.55)  # a second object that stays where it is


def _two_tone(img: np.ndarray, P: np.ndarray, xy) -> None:
    """The moved box's right half and its left half's lower half in other colours: an object with texture
    along both image axes."""
    _draw_box(img, P, (xy[0] + BOX[0] / 4, xy[1]), (150, 150, 190), BOX * [0.5, 1.0, 1.0])
    _draw_box(img, P, (xy[0] - BOX[0] / 4, xy[1]), (90, 140, 200), BOX * [0.5, 1.0, 0.5])


def _frames(P, old_xy, new_xy, n=5, hidden=False, in_front=None, textured=False):
    rng = np.random.default_rng(0)
    table = np.zeros((240, 320, 3), np.uint8)
    table[:] = (120, 80, 50)
    _draw_box(table, P, STILL_XY, (60, 60, 70))
    before = table.copy()
    _draw_box(before, P, old_xy, (210, 210, 200))
    after = table.copy()
    if not hidden:
        _draw_box(after, P, new_xy, (210, 210, 200))
    if textured:
        _two_tone(before, P, old_xy)
        _two_tone(after, P, new_xy)
    if in_front is not None:  # another object, in front of part of the new place
        _draw_box(after, P, in_front, (40, 90, 40))
    after[40:52, 250:300] = (200, 150, 120)  # the person's forearm rests elsewhere afterwards
    after = np.clip(after.astype(np.float64) * 1.25, 0, 255)  # the lights
    noisy = lambda img: np.clip(img[None] + rng.normal(0, 3, (n,) + img.shape), 0, 255).astype(np.uint8)  # noqa: E731
    return noisy(before.astype(np.float64)), noisy(after)


def test_pixel_ray_and_project_are_inverse():
    P = _camera()
    X = np.array([0.1, -0.3, 0.8])
    centre, direction = pixel_ray(P, project(P, X))
    lam = (X - centre) @ direction / (direction @ direction)
    np.testing.assert_allclose(centre + lam * direction, X, atol=1e-9)


@pytest.mark.parametrize("old_xy, new_xy", [((-0.2, -0.45), (0.05, -0.30)), ((0.1, -0.30), (-0.15, -0.48))])
def test_moved_box_is_found_at_its_new_place(old_xy, new_xy):
    P = _camera()
    before, after = _frames(P, old_xy, new_xy)
    objects = np.array([STILL_XY, old_xy])
    for guess in (0, 1):  # the scene decides which object moved, whatever the guess
        res = scene_place(before, after, P, objects, guess, TABLE_Z)
        assert res.found and res.reason == "" and res.moved == 1 and not res.still
        assert np.linalg.norm(res.xy - np.array(new_xy)) < 0.015


@pytest.mark.parametrize("new_xy, in_front", [((-0.17, -0.45), None),  # moved by half its width: one changed region
                                              ((0.05, -0.30), (0.0, -0.24))])  # its left part behind another
def test_a_short_move_and_a_partly_hidden_place_are_found(new_xy, in_front):
    # textured: a uniform object moved by less than its width matches at any overlap (module docstring)
    P = _camera()
    old_xy = (-0.2, -0.45)
    before, after = _frames(P, old_xy, new_xy, in_front=in_front, textured=True)
    res = scene_place(before, after, P, np.array([STILL_XY, old_xy]), 1, TABLE_Z)
    assert res.found and res.moved == 1
    assert np.linalg.norm(res.xy - np.array(new_xy)) < 0.015


def test_a_place_off_the_table_is_not_taken():
    # the moved box partly hidden at its new place, and a box just like it off the table (a white shirt
    # behind a white cup): the better match is off the table, the place is the one on it
    P = _camera()
    old_xy, new_xy, decoy = (-0.2, -0.45), (0.05, -0.30), (-0.2, -0.03)
    before, after = _frames(P, old_xy, new_xy, in_front=(0.0, -0.24))
    drawn = np.zeros_like(after[0])
    _draw_box(drawn, P, decoy, (255, 255, 255))
    after[:, drawn.any(-1)] = (255, 255, 250)  # the moved box's colour under the brighter lights
    objects = np.array([STILL_XY, old_xy])
    anywhere = scene_place(before, after, P, objects, 1, TABLE_Z)
    assert anywhere.found and np.linalg.norm(anywhere.xy - np.array(decoy)) < 0.03
    on_table = scene_place(before, after, P, objects, 1, TABLE_Z, table_xy=((-0.9, 0.9), (-0.85, -0.15)))
    assert on_table.found and np.linalg.norm(on_table.xy - np.array(new_xy)) < 0.015


def test_a_scene_where_nothing_was_moved_is_still():
    # a pointing: the lights and the person's posture change, no object does
    P = _camera()
    before, after = _frames(P, (-0.2, -0.45), (-0.2, -0.45))
    res = scene_place(before, after, P, np.array([STILL_XY, (-0.2, -0.45)]), 1, TABLE_Z)
    assert res.still and res.moved == -1 and not res.found


def test_hidden_new_place_is_flagged_not_guessed():
    P = _camera()
    before, after = _frames(P, (-0.2, -0.45), (0.05, -0.30), hidden=True)
    res = scene_place(before, after, P, np.array([STILL_XY, (-0.2, -0.45)]), 0, TABLE_Z)
    assert res.moved == 1 and not res.found and np.isnan(res.xy).all() and res.reason


def test_reader_takes_the_rest_frames_around_the_movement():
    P = _camera()
    before, after = _frames(P, (-0.2, -0.45), (0.05, -0.30), n=10)
    moving = np.repeat(after[:1] // 2, 20, axis=0)  # anything while the person moves
    frames = np.concatenate([before, moving, after])
    read = place_reader(frames, P, fps=10.0, first_frame=0, margin=2, rest_s=0.5, height=0.05, table_z=TABLE_Z)
    objects = np.array([STILL_XY, (-0.2, -0.45)])
    res = read(12, 29, objects, 1)
    assert res.found and np.linalg.norm(res.xy - np.array([0.05, -0.30])) < 0.015
    early = read(2, 29, objects, 1)  # no frame at rest before the movement
    assert not early.found and early.moved == -1


def test_a_movement_to_the_recordings_end_is_read_only_as_still():
    """The recording stops as the arm comes back: its last frames show a pointing's scene still; after a
    transfer they are not read for a place (the hand may still be on the object)."""
    P = _camera()
    objects = np.array([STILL_XY, (-0.2, -0.45)])
    for new_xy, still in (((-0.2, -0.45), True), ((0.05, -0.30), False)):
        before, after = _frames(P, (-0.2, -0.45), new_xy, n=10)
        frames = np.concatenate([before, np.repeat(after[:1] // 2, 20, axis=0), after[:5]])
        read = place_reader(frames, P, fps=10.0, first_frame=0, margin=2, rest_s=0.5, height=0.05, table_z=TABLE_Z)
        res = read(12, len(frames) - 1, objects, 1)
        assert res.still == still and res.moved == -1 and not res.found
        assert read(12, len(frames) - 3, objects, 1).found != still  # with frames after it: the usual reading


def test_bad_input_names_the_argument():
    P = _camera()
    before, after = _frames(P, (-0.2, -0.45), (0.05, -0.30), n=2)
    xy = np.zeros((2, 2))
    with pytest.raises(ValueError, match="P"):
        scene_place(before, after, np.zeros((3, 3)), xy, 0, 0.8)
    with pytest.raises(ValueError, match="objects_xy"):
        scene_place(before, after, P, np.array([[np.nan, 0.0]]), 0, 0.8)
    with pytest.raises(ValueError, match="target"):
        scene_place(before, after, P, xy, 2, 0.8)
    with pytest.raises(ValueError, match="after"):
        scene_place(before, after[:, :100], P, xy, 0, 0.8)
    with pytest.raises(ValueError, match="before"):
        scene_place(before[0], after, P, xy, 0, 0.8)
    for name in ("search_m", "object_half_m", "cap"):
        with pytest.raises(ValueError, match=name):
            scene_place(before, after, P, xy, 0, 0.8, **{name: 0.0})
    with pytest.raises(ValueError, match="min_changed"):
        scene_place(before, after, P, xy, 0, 0.8, min_changed=1.5)
    with pytest.raises(ValueError, match="table_z"):
        scene_place(before, after, P, xy, 0, float("nan"))
    for bounds in (((0.5, -0.5), (-0.8, -0.2)), ((-0.5, 0.5),), ((-0.5, np.inf), (-0.8, -0.2))):
        with pytest.raises(ValueError, match="table_xy"):
            scene_place(before, after, P, xy, 0, 0.8, table_xy=bounds)


def test_moved_object_decides_only_when_one_position_changed():
    changed = np.zeros((50, 50), bool)
    changed[8:13, 8:13] = True
    assert moved_object(changed, np.array([[10.0, 10.0], [40.0, 40.0]]), 2.0) == 0
    changed[38:43, 38:43] = True  # both changed: not decided
    assert moved_object(changed, np.array([[10.0, 10.0], [40.0, 40.0]]), 2.0) == -1
    assert moved_object(changed, np.array([[25.0, 25.0], [-5.0, 60.0]]), 2.0) == -1  # nothing changed there


def test_the_video_overrules_the_phmms_action_where_it_shows_an_object_moved_or_none(monkeypatch):
    from lfd_jax.imitation._src import recognition  # `movement` is replaced where `recognise_demo` finds it
    from types import SimpleNamespace

    from lfd_jax.imitation import ScenePlace

    n = 40
    arc = np.sin(np.pi * np.linspace(0.0, 1.0, n))
    tracked = recognition.Tracked(np.stack([0.3 * arc, -0.4 + 0.1 * arc, -0.3 + 0.0 * arc], 1), np.ones(n, bool),
                                  np.zeros((n, 2)), 0)
    objects = np.array([[0.0, -0.4], [0.2, -0.45], [-0.2, -0.5]])
    handover, new_place = np.array([-0.1, -0.3]), np.array([0.1, -0.3])

    online = SimpleNamespace(phmms=(None, None), options=SimpleNamespace(max_frames=n))  # the PHMMs stand in

    def recognise(moved: int, kind: str = "point", still: bool = False):
        monkeypatch.setattr(recognition, "movement", lambda *_: (kind, objects[0] + 0.01, 5, 30))   # the PHMMs' answer
        monkeypatch.setattr(recognition, "likeliest_object", lambda *_: 0)                          # the same object

        def scene(start, end, objects_xy, target):
            assert (start, end) == (5, 30)
            return ScenePlace(moved, new_place if moved >= 0 else np.full(2, np.nan), moved >= 0, "", still)
        return recognition.recognise_demo(online, tracked, np.zeros(3), 3, objects, handover, scene=scene)

    r = recognise(1)                                              # the video: object 1 moved to new_place
    assert (r.kind, r.kind_phmm, r.target, r.target_phmm, r.place_from) == ("transfer", "point", 1, 0, "scene")
    np.testing.assert_allclose(r.place_xy, new_place)
    assert 5 <= r.grasp_frame < r.putdown_frame <= 30
    r = recognise(-1)                                             # the video does not decide: the PHMMs stand
    assert (r.kind, r.kind_phmm, r.target, r.grasp_frame) == ("point", "point", 0, -1)
    np.testing.assert_allclose(r.place_xy, handover)
    assert recognise(-1, "transfer").kind == "transfer"
    r = recognise(-1, "transfer", still=True)                     # the PHMMs' transfer moved nothing
    assert (r.kind, r.kind_phmm, r.target, r.grasp_frame) == ("point", "transfer", 0, -1)


# beside the other box, not in front of it in the image (else its old position changes too: not decided)
_table_xy = st.tuples(st.one_of(st.floats(-0.3, STILL_XY[0] - 0.1), st.floats(STILL_XY[0] + 0.1, 0.3)),
                      st.floats(-0.5, -0.2))


@settings(max_examples=12, deadline=None)
@given(_table_xy, _table_xy)
def test_a_textured_box_moved_anywhere_on_the_table_is_found(old_xy, new_xy):
    # moved farther than its size (a short move is ambiguous where the object has no texture at that scale:
    # module docstring); whole-pixel displacements: within 2 px in the image (1 px: 0.5-1.5 cm on the table)
    assume(np.hypot(*np.subtract(old_xy, new_xy)) >= 0.08)
    P = _camera()
    before, after = _frames(P, old_xy, new_xy, textured=True)
    res = scene_place(before, after, P, np.array([STILL_XY, old_xy]), 1, TABLE_Z)
    assert res.found and res.moved == 1
    found_px, true_px = (project(P, np.r_[xy, TABLE_Z + BOX[2] / 2]) for xy in (res.xy, new_xy))
    assert np.linalg.norm(found_px - true_px) <= 2.0
