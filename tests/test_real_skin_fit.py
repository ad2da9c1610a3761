"""lfd_jax.fit_real_skin_model (the one skin model fitted on real labelled pixels) and lfd_jax.VideoWriter
(an overlay written chunk by chunk)."""
from pathlib import Path

import cv2
import numpy as np
import pytest

import hog_jax
from lfd_jax import VideoWriter, fit_real_skin_model

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
SKIN_RGB, OTHER_RGB = np.array([190.0, 130.0, 105.0]), np.array([60.0, 90.0, 160.0])


def _uci_folder(folder: Path) -> Path:
    """A UCI-layout file (B G R label) of skin around SKIN_RGB and other pixels around OTHER_RGB and greys."""
    rng = np.random.default_rng(0)
    skin = np.clip(rng.normal(SKIN_RGB, 8, (300, 3)), 0, 255)
    other = np.clip(np.concatenate([rng.normal(OTHER_RGB, 15, (200, 3)), rng.uniform(0, 255, (100, 1)).repeat(3, 1)]),
                    0, 255)
    rows = [f"{b:.0f}\t{g:.0f}\t{r:.0f}\t1" for r, g, b in skin] + [f"{b:.0f}\t{g:.0f}\t{r:.0f}\t2" for r, g, b in other]
    (folder / "skin_nonskin_uci.tsv").write_text("R\tG\tB\tT\n" + "\n".join(rows) + "\n")
    return folder


def test_fit_on_uci_pixels_alone(tmp_path):
    model = fit_real_skin_model(_uci_folder(tmp_path), n_pixels=400)  # fewer pixels than asked: all of them
    assert model.skin.means.shape == (4, 3) and float(model.threshold) == 1.0  # (Cr, Cb, Y), the chosen threshold
    ratio = np.asarray(hog_jax.skin_log_ratio(model, np.stack([SKIN_RGB, OTHER_RGB]).astype(np.float32)))
    assert ratio[0] > 1.0 > ratio[1]
    with pytest.raises(FileNotFoundError, match="skin_nonskin_uci.tsv"):
        fit_real_skin_model(tmp_path / "absent")
    with pytest.raises(ValueError, match="n_pixels"):
        fit_real_skin_model(tmp_path, n_pixels=1)


@pytest.mark.skipif(not (DATA / "skin_nonskin_uci.tsv").is_file(), reason=f"no real skin pixels under {DATA}")
def test_fit_on_the_real_pixels_marks_real_skin():
    model = fit_real_skin_model(DATA, n_pixels=4000)
    ratio = np.asarray(hog_jax.skin_log_ratio(model, np.array([[200, 140, 110], [40, 60, 170]], np.float32)))
    assert ratio[0] > float(model.threshold) > ratio[1]


def test_video_writer_appends_chunks(tmp_path):
    frames = np.random.default_rng(0).integers(0, 255, (6, 16, 24, 3)).astype(np.uint8)
    with VideoWriter(tmp_path / "out.avi", fps=10.0) as out:
        out.write(frames[:4])
        out.write(frames[4:])
        with pytest.raises(ValueError, match="frames: expected frames of"):
            out.write(frames[:1, :8])
    assert out.path.suffix == ".mp4"
    capture = cv2.VideoCapture(str(out.path))
    assert int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == 6
    capture.release()
