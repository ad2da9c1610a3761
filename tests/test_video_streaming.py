"""Streaming: the video readers yield the frames the whole-clip loaders return, the front end run chunk
by chunk (its background, level-set and tracker states carried) gives the whole-video result, and a
long video streamed through the segmentation keeps memory bounded."""
import os
import re
import sys
from pathlib import Path

import jax
import numpy as np
import pytest

import hog_jax.video as hv
import lfd_jax as L
from tests.video_scene import PERSON_RGB, SKIN_RGB, toy_skin_model, write_video

H, W, T, START, CHUNK = 24, 32, 12, 7, 5
CAMERA = hv.StereoCamera(focal_px=30.0, baseline_m=0.12, width=W, height=H)
OPTIONS = hv.VideoOptions(person_frames=4, background=hv.BackgroundOptions.for_fps(10.0))
TRACKING = hv.HandFaceOptions(tracking=hv.TrackOptions(min_init=2))


@pytest.fixture(autouse=True)
def _quiet(monkeypatch):
    monkeypatch.setenv("LFD_NO_PROGRESS", "1")


def _frame(t, rng, h=H, w=W):
    """One frame: a textured background; from frame 3 a person block entering from the right with a
    face patch at its top and a hand patch that moves down."""
    img = np.where((np.add.outer(np.arange(h) // 4, np.arange(w) // 4) % 2)[..., None] == 1, 150.0, 100.0)
    img = np.broadcast_to(img, (h, w, 3)).copy()
    if t >= 3:
        left = max(w - 4 * (t - 2), 12)
        img[4:h - 2, left:left + 12] = PERSON_RGB
        img[5:9, left + 7:left + 11] = SKIN_RGB
        top = 12 + max(t - START, 0) // 2
        img[top:top + 4, left + 1:left + 4] = SKIN_RGB
    return np.clip(img + rng.normal(0, 3, img.shape), 0, 255).astype(np.uint8)


def _stereo():
    rng = np.random.default_rng(0)
    left = np.stack([_frame(t, rng) for t in range(T)])
    right = np.concatenate([left[:, :, 2:], left[:, :, -1:].repeat(2, axis=2)], axis=2)
    return left, right


def _chunks(*arrays, size=CHUNK):
    for i in range(0, len(arrays[0]), size):
        yield tuple(a[i:i + size] for a in arrays) if len(arrays) > 1 else arrays[0][i:i + size]


@pytest.fixture(scope="module")
def skin():
    return toy_skin_model()


@pytest.fixture(scope="module")
def models(skin):
    return hv.fit_video_models(jax.random.key(1), skin, _stereo()[0], START, OPTIONS)[0]


def _equal(a, b):
    jax.tree.map(lambda x, y: np.testing.assert_array_equal(np.asarray(x), np.asarray(y)), a, b)


def test_streamed_front_end_equals_the_whole_video_run(skin, models):
    left, right = _stereo()
    whole = hv.front_end(jax.random.key(1), skin, left, right, START, CAMERA, OPTIONS, TRACKING)
    parts = list(hv.stream_front_end(jax.random.key(1), skin, _chunks(left, right), START, CAMERA, OPTIONS,
                                     TRACKING, total=T))
    assert [len(p.labels) for p in parts] == [5, 5, 2]
    _equal(hv.join_chunks(parts), whole)  # the same masks, tracks and hand tracks, exactly
    assert whole.tracked[START:].any() and (whole.labels[START:] == hv.SKIN).any()
    # the pieces: the mono stream and the stereo stream against their whole-video functions
    _equal(hv.join_chunks(list(hv.stream_recording(models, _chunks(left), START, OPTIONS))),
           hv.segment_recording(models, left, START, OPTIONS))
    seg = hv.join_chunks(list(hv.stream_stereo(models, _chunks(left, right), START, CAMERA, OPTIONS, TRACKING)))
    _equal(seg, hv.segment_stereo(models, left, right, START, CAMERA, OPTIONS, TRACKING))


def test_mono_tracks_do_not_depend_on_the_chunks(models):
    """`track_mono` in chunks of 5 (the tracker's state carried) equals one chunk of the whole clip; the
    face is tracked on the segmented frames and nothing before `start` counts as tracked."""
    left, _ = _stereo()
    whole = hv.track_mono(models, left, START, OPTIONS, TRACKING, chunk=T)
    _equal(hv.track_mono(models, left, START, OPTIONS, TRACKING, chunk=CHUNK), whole)
    assert not whole.tracked[:START].any() and whole.tracked[START:, hv.FACE].all()
    with pytest.raises(ValueError, match="chunk"):
        hv.track_mono(models, left, START, OPTIONS, TRACKING, chunk=0)


def test_segment_chunk_carries_the_state_and_names_bad_input(models):
    left, _ = _stereo()
    state = hv.init_segment_state(left[0], OPTIONS)
    assert int(state.frame) == 0 and state.phi.shape == (4, H, W)
    state, seg = hv.segment_chunk(models, state, left[:3], START, OPTIONS, pad_to=CHUNK)
    assert int(state.frame) == 3 and seg.labels.shape == (3, H, W)  # the padded frames count for nothing
    with pytest.raises(ValueError, match="^state"):
        hv.segment_chunk(models, state, left[None, :3], START, OPTIONS)
    with pytest.raises(ValueError, match="^pad_to"):
        hv.segment_chunk(models, state, left[:3], START, OPTIONS, pad_to=2)
    with pytest.raises(ValueError, match="^start"):
        hv.segment_chunk(models, state, left[:3], 0, OPTIONS)
    with pytest.raises(ValueError, match="^frames"):
        hv.segment_chunk(models, state, left[:3, :, :, :2], START, OPTIONS)
    with pytest.raises(ValueError, match="^state"):
        hv.track_chunk(hv.connected_blobs(left[:3, :, :, 0] > 128), "a state")


def test_readers_yield_the_frames_of_the_whole_loaders(tmp_path):
    import cv2
    from PIL import Image

    frames, _ = _stereo()
    video = write_video(tmp_path / "clip.avi", frames)
    chunks = list(L.iter_video(video, chunk=CHUNK))
    assert [len(c) for c in chunks] == [5, 5, 2] and chunks[0].dtype == np.uint8
    np.testing.assert_array_equal(np.concatenate(chunks), L.load_video(video).frames)
    assert L.video_info(video) == L.VideoInfo(H, W, 10.0, T)
    assert sum(len(c) for c in L.iter_video(video, chunk=CHUNK, max_frames=7)) == 7
    # an animated GIF (PNG-like palette: compare with what PIL decodes)
    gif = tmp_path / "clip.gif"
    Image.fromarray(frames[0]).save(gif, save_all=True, append_images=[Image.fromarray(f) for f in frames[1:]],
                                    duration=100, loop=0)
    gif_frames = np.concatenate(list(L.iter_video(gif, chunk=CHUNK)))
    assert gif_frames.shape == frames.shape and L.video_info(gif).n_frames == T
    np.testing.assert_array_equal(gif_frames, L.load_video(gif).frames)
    # a folder of images
    for k, f in enumerate(frames):
        cv2.imwrite(str(tmp_path / f"f{k:02d}.png"), cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    folder = list(L.iter_image_folder(tmp_path, chunk=CHUNK))
    np.testing.assert_array_equal(np.concatenate(folder), frames)
    assert L.video_info(tmp_path) == L.VideoInfo(H, W, None, T)
    # a stereo pair in step, and the errors name the argument
    write_video(tmp_path / "right.avi", frames[::-1])
    pairs = list(L.iter_stereo_videos(video, tmp_path / "right.avi", chunk=CHUNK))
    stereo = L.load_stereo_videos(video, tmp_path / "right.avi")
    np.testing.assert_array_equal(np.concatenate([p[1] for p in pairs]), stereo.right)
    write_video(tmp_path / "short.avi", frames[:8])
    with pytest.raises(ValueError, match="^right: 8 frames, the left video has 12"):
        list(L.iter_stereo_videos(video, tmp_path / "short.avi", chunk=CHUNK))
    with pytest.raises(ValueError, match="^path: no such file"):
        L.iter_video(tmp_path / "none.avi")
    with pytest.raises(ValueError, match="^chunk"):
        L.iter_video(video, chunk=0)


REACH = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "reach_grasp" / "teaser_movement.gif"


@pytest.mark.skipif(not REACH.is_file(), reason=f"no reach clip at {REACH} (../shared/data/reach_grasp)")
def test_real_gif_streams():
    info = L.video_info(REACH)
    assert info == L.VideoInfo(238, 260, 10.0, 58)
    assert [len(c) for c in L.iter_video(REACH, chunk=25)] == [25, 25, 8]


def _peak_rss_kib():
    return int(re.search(r"VmHWM:\s+(\d+)", Path("/proc/self/status").read_text()).group(1))


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.access("/proc/self/clear_refs", os.W_OK),
                    reason="needs Linux's /proc/self/clear_refs to reset the peak RSS")
def test_a_long_streamed_video_keeps_memory_bounded(models):
    """1,200 frames of 48 x 64 generated frame by frame through the streaming segmentation (the
    background model, the colour scores and the level sets) in chunks of 40: the peak RSS grows by
    less than 8 MiB over the compiled first chunk's (about 3 MiB measured; it stayed under 4 MiB
    over 8,000 frames). The video alone is 10.5 MiB as uint8, its masks 3.5 MiB and its colour
    densities 42 MiB: the bound shows that neither the frames, nor the masks, nor any per-frame array
    of the whole video is held."""
    h, w, n, chunk = 48, 64, 1200, 40
    rng = np.random.default_rng(2)

    def chunks():
        for i in range(0, n, chunk):
            yield np.stack([_frame(t, rng, h, w) for t in range(i, min(i + chunk, n))])

    stream = hv.stream_recording(models, chunks(), START, OPTIONS, total=n)
    skin_frames = int(np.sum(np.asarray(next(stream).labels) == hv.SKIN))  # compiled
    Path("/proc/self/clear_refs").write_text("5")  # the peak RSS restarts from the current RSS
    before = _peak_rss_kib()
    count = chunk
    for seg in stream:
        count += len(seg.labels)
        skin_frames += int(np.sum(np.asarray(seg.labels) == hv.SKIN))
    grown_mib = (_peak_rss_kib() - before) / 1024
    assert count == n and skin_frames > 0
    assert grown_mib < 8.0, grown_mib


def test_fine_it_max_caps_the_fine_scale_only():
    """`LevelSetOptions.fine_it_max` bounds the fine scale's iterations after a coarse one; None
    keeps `it_max` (the default, unchanged results); below 1 it is a ValueError naming it."""
    rng = np.random.default_rng(3)
    labels = np.zeros((32, 32), int)
    labels[8:24, 10:26] = 1
    scores = np.where(np.arange(2)[:, None, None] == labels, 0.0, -2.0) + rng.normal(0, 1.5, (4, 2, 32, 32))
    structure = hv.LevelSetStructure(2, (32, 32), (16, 16))
    free = hv.segment_video(structure, scores.astype(np.float32), options=hv.LevelSetOptions())
    capped = hv.segment_video(structure, scores.astype(np.float32), options=hv.LevelSetOptions(fine_it_max=2))
    assert np.asarray(free.iterations).max() > 2 and np.asarray(capped.iterations).max() == 2
    assert int(capped.iterations_coarse[0]) == int(free.iterations_coarse[0])  # the coarse scale is not capped
    with pytest.raises(ValueError, match="^fine_it_max"):
        hv.segment_video(structure, scores.astype(np.float32), options=hv.LevelSetOptions(fine_it_max=0))
