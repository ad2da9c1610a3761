"""experiments.grasp_recognition.real_photos.green_lines: the drawn green object boxes of gtea frames are
found from the pixels (straight green runs), small green objects are left alone."""
import cv2
import numpy as np

from experiments.grasp_recognition.real_photos import green_lines

SKIN_BGR, GREEN_BGR = (115, 140, 205), (0, 255, 0)


def test_drawn_green_box_found_and_small_green_objects_left():
    rng = np.random.default_rng(0)
    bgr = np.clip(rng.normal(120, 10, size=(120, 160, 3)), 0, 255).astype(np.uint8)
    bgr[40:90, 30:80] = SKIN_BGR                                  # a hand the box line crosses
    drawn = np.zeros((120, 160), np.uint8)
    cv2.rectangle(drawn, (20, 30), (100, 100), 1, 2)              # the reference: the line's own pixels
    bgr[drawn > 0] = GREEN_BGR
    bgr[10:22, 120:132] = GREEN_BGR                               # a green object 12 px across
    bgr[60, 120:135] = GREEN_BGR                                  # a short green stroke, 15 px
    # the frames are JPEG files: the drawn green blurs into the skin it crosses
    bgr = cv2.imdecode(cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, 90])[1], cv2.IMREAD_COLOR)
    mask = green_lines(bgr)
    assert mask[drawn > 0].all()
    # grown by 2 px, no further: 3 px off the line is left
    assert not mask[cv2.dilate(drawn, np.ones((7, 7), np.uint8)) == 0].any()
    assert not mask[10:22, 120:132].any() and not mask[60, 120:135].any()
