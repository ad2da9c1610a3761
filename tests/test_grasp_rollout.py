"""Grasp strategy, rollouts on every backend, virtual fingers, the experiment's smoke test."""
import itertools

import jax.numpy as jnp
import numpy as np
import pytest

from sim.grasping import GRASP_CLASSES, VOLAR_GRASPS
from sim.grasping import PlanOptions, SUBSTEPS, peak_touch, resolve_backend, rollout_grasps, warp_status
from sim.grasping import (ALPHA0, APPROACH, CLOSE, CONTROL_DT_S, HOLD_S, RETRACT, TOUCH_THRESHOLD_N,
    controller_step, initial_state, plan_trials)
from sim.hands import grasp_model
from sim.hands import VirtualFingers, entities_from_links, group_virtual_fingers, match_virtual_fingers
from tests.grasp_equivalence import native_run


def _plan(hand, grasps, tactile=True, offsets=None, hold_s=HOLD_S):
    grasps = np.asarray(grasps)
    b = len(grasps)
    offsets = np.zeros((b, 2)) if offsets is None else offsets
    return plan_trials(hand, grasps, offsets, np.zeros(b), np.full(b, tactile), np.arange(b),
                       options=PlanOptions(hold_s=hold_s))


# ------------------------------------------------------------------ controller (pure function)

def _sensors(layout, nsensordata, obj, touch_links, contact_pos):
    """Synthetic sensordata (1, S): touch on `touch_links`, a contact with object `obj` at contact_pos."""
    s = np.zeros((1, nsensordata), np.float32)
    for ln in touch_links:
        s[0, layout.touch[ln]] = 1.0
        adr = layout.contact[ln, obj]
        s[0, adr:adr + 7] = [1, *contact_pos, 0, 0, 1]
    s[0, layout.object_quat[obj]] = 1.0
    s[0, layout.palm_quat] = 1.0
    s[0, layout.palm_pos:layout.palm_pos + 3] = [0.0, -0.1, 0.09]
    return jnp.asarray(s)


@pytest.fixture(scope="module")
def barrett():
    model, layout = grasp_model("barrett")
    return model, layout


def test_approach_moves_at_most_one_step_towards_the_goal(barrett):
    model, layout = barrett
    params, _ = _plan("barrett", [1])
    state = initial_state(params, layout.n_links)
    new, ctrl = controller_step(state, _sensors(layout, model.nsensordata, 0, [], [0, 0, 0]), params, layout)
    moved = np.linalg.norm(np.asarray(new.cmd - state.cmd))
    assert 0 < moved <= 0.25 * CONTROL_DT_S + 1e-6
    assert int(new.phase[0]) == APPROACH
    np.testing.assert_allclose(np.asarray(ctrl[0, :3]), np.asarray(new.cmd[0]))
    np.testing.assert_allclose(np.asarray(ctrl[0, 6:]), params.open_[0])


def test_tactile_correction_replans_with_alpha(barrett):
    """A first touch on a finger (not the palm) of a volar grasp: retract, p_new = a c + (1 - a) p_old,
    a <- a^2; with correction off, or with a palm touch, close instead."""
    model, layout = barrett
    params, _ = _plan("barrett", [1])
    state = initial_state(params, layout.n_links)
    c = np.array([0.03, -0.05, 0.1])
    finger = _sensors(layout, model.nsensordata, 0, [2], c)
    new, _ = controller_step(state, finger, params, layout)
    assert int(new.phase[0]) == RETRACT and int(new.n_corr[0]) == 1 and not bool(new.palm_first[0])
    np.testing.assert_allclose(np.asarray(new.goal[0]), ALPHA0 * c + (1 - ALPHA0) * params.goal[0], atol=1e-6)
    assert float(new.alpha[0]) == pytest.approx(ALPHA0 ** 2)
    off, _ = _plan("barrett", [1], tactile=False)
    new_off, _ = controller_step(initial_state(off, layout.n_links), finger, off, layout)
    assert int(new_off.phase[0]) == CLOSE
    palm = _sensors(layout, model.nsensordata, 0, [0], c)
    new_palm, _ = controller_step(state, palm, params, layout)
    assert int(new_palm.phase[0]) == CLOSE and bool(new_palm.palm_first[0])
    assert TOUCH_THRESHOLD_N < 1.0


def test_open_loop_grasps_ignore_touches(barrett):
    model, layout = barrett
    params, _ = _plan("barrett", [9])
    assert 9 not in VOLAR_GRASPS
    state = initial_state(params, layout.n_links)
    new, _ = controller_step(state, _sensors(layout, model.nsensordata, 3, [2], [0, 0, 0.02]), params, layout)
    assert int(new.phase[0]) == APPROACH and bool(new.touched[0])


def _peak_touch_reference(substeps, layout):
    """peak_touch by loops (float64): touch = max over substeps; each contact sensor's 7 values from the
    latest substep whose `found` > 0, else from the last substep; everything else from the last substep."""
    b, k, _ = substeps.shape
    out = substeps[:, -1].astype(np.float64).copy()
    for i in range(b):
        for adr in layout.touch:
            out[i, adr] = max(substeps[i, j, adr] for j in range(k))
        for adr in layout.contact.ravel():
            hits = [j for j in range(k) if substeps[i, j, adr] > 0]
            out[i, adr:adr + 7] = substeps[i, hits[-1] if hits else k - 1, adr:adr + 7]
    return out


def test_peak_touch_keeps_the_position_of_the_substep_that_found_the_contact(barrett):
    """Regression: a contact found in an early substep of a control period must reach the
    controller with that substep's position and normal (the last substep's were zeros, so the tactile
    correction of MAP §III fired without a contact position). numpy and jax inputs, against loops."""
    model, layout = barrett
    rng = np.random.default_rng(0)
    sub = rng.normal(size=(5, SUBSTEPS, model.nsensordata)).astype(np.float32)
    found = layout.contact.ravel()
    sub[:, :, found] = rng.choice([0.0, 0.0, 0.0, 1.0, 2.0], size=(5, SUBSTEPS, len(found)))
    sub[0, :, found] = 0.0                          # trial 0: no contact found in any substep
    sub[1, :, found] = 0.0
    sub[1, 2, found] = 1.0                          # trial 1: only substep 2 found them (a brief tap)
    sub[1, -1, layout.contact.ravel()[:, None] + np.arange(1, 7)] = 0.0   # ... the last substep has no position
    sub[:, :, layout.touch] = np.abs(sub[:, :, layout.touch])
    ref = _peak_touch_reference(sub, layout)
    np.testing.assert_array_equal(peak_touch(sub, layout), ref)
    np.testing.assert_array_equal(np.asarray(peak_touch(jnp.asarray(sub), layout)), ref)
    adr = layout.contact[2, 0]
    np.testing.assert_array_equal(peak_touch(sub, layout)[1, adr:adr + 7], sub[1, 2, adr:adr + 7])


# ------------------------------------------------------------------ virtual fingers

def _brute_force_match(r_pos, r_nrm, h_pos, h_nrm):
    """All injective assignments of the smaller set into the larger; min summed distance."""
    best = None
    small, large = (r_pos, h_pos) if len(r_pos) <= len(h_pos) else (h_pos, r_pos)
    for perm in itertools.permutations(range(len(large)), len(small)):
        d = sum(np.linalg.norm(small[i] - large[j]) for i, j in enumerate(perm))
        if best is None or d < best[0]:
            pairs = [(i, j) if len(r_pos) <= len(h_pos) else (j, i) for i, j in enumerate(perm)]
            best = (d, pairs)
    pairs = best[1]
    pos = np.mean([np.linalg.norm(r_pos[i] - h_pos[j]) for i, j in pairs]) * 1e3
    ang = np.mean([np.degrees(np.arccos(np.clip(r_nrm[i] @ h_nrm[j], -1, 1))) for i, j in pairs])
    return pos, ang, len(pairs)


def test_matching_equals_brute_force():
    rng = np.random.default_rng(0)
    for trial in range(5):
        n_r, n_h = rng.integers(1, 7, size=2)
        vf = []
        for n in (n_r, n_h):
            valid = np.zeros(6, bool)
            valid[rng.choice(6, n, replace=False)] = True
            nrm = rng.normal(size=(6, 3))
            vf.append(VirtualFingers(jnp.asarray(valid[None]), jnp.asarray(rng.normal(0, 0.05, (1, 6, 3))),
                                     jnp.asarray((nrm / np.linalg.norm(nrm, axis=1, keepdims=True))[None])))
        err = match_virtual_fingers(*vf)
        r, h = vf
        pick = lambda v, k: np.asarray(getattr(v, k)[0])[np.asarray(v.valid[0])]  # noqa: E731
        pos, ang, n = _brute_force_match(pick(r, "pos"), pick(r, "normal"), pick(h, "pos"), pick(h, "normal"))
        assert float(err.position_mm[0]) == pytest.approx(pos, rel=1e-4)
        assert float(err.orientation_deg[0]) == pytest.approx(ang, rel=1e-3, abs=1e-2)
        assert int(err.n_matched[0]) == n == min(n_r, n_h)


def test_grouping_merges_fingers_with_similar_normals():
    """Two fingers pressing from the same side form one virtual finger; the palm stays alone."""
    contacts = np.zeros((1, 4, 7))
    contacts[0, 0] = [1, 0, -0.04, 0, 0, -1, 0]      # palm
    contacts[0, 1] = [1, 0.01, 0.04, 0, 0, 1, 0]      # finger 1
    contacts[0, 2] = [1, -0.01, 0.04, 0, 0, 0.96, 0.28]  # finger 2, 16 degrees away
    contacts[0, 3] = [1, 0.04, 0, 0, 1, 0, 0]         # finger 3, 90 degrees away
    vf = group_virtual_fingers(entities_from_links(jnp.asarray(contacts, jnp.float32), jnp.array([0, 1, 2, 3])))
    assert np.asarray(vf.valid[0]).tolist() == [True, True, False, True, False, False]
    np.testing.assert_allclose(np.asarray(vf.pos[0, 1]), [0.0, 0.04, 0.0], atol=1e-6)


# ------------------------------------------------------------------ backends

def test_bad_input():
    with pytest.raises(ValueError, match="backend"):
        resolve_backend("cuda")
    if warp_status():
        with pytest.raises(ValueError, match="not available on this machine"):
            resolve_backend("mjx-warp")
        assert resolve_backend("auto") == "native"
    with pytest.raises(ValueError, match="grasps"):
        _plan("barrett", [3])
    with pytest.raises(ValueError, match="hand"):
        _plan("shadow", [1])
    with pytest.raises(ValueError, match="offsets"):
        _plan("barrett", [1], offsets=np.array([[0.5, 0.0]]))
    with pytest.raises(ValueError, match="hold_s"):
        _plan("barrett", [1], hold_s=0.0)
    with pytest.raises(ValueError, match="objects"):
        plan_trials("barrett", [1], np.zeros((1, 2)), [0.0], [True], [0], objects=[3])
    params, start = _plan("barrett", [1])
    bad = params._replace(goal=np.array([[np.nan, 0, 0]], np.float32))
    with pytest.raises(ValueError, match="params.goal"):
        rollout_grasps("barrett", bad, start, backend="native")
    with pytest.raises(ValueError, match="object_start"):
        rollout_grasps("barrett", params, np.zeros((2, 3)), backend="native")


def test_the_plan_is_made_for_the_handled_object():
    # an Abducted Thumb (open-loop, from the side) planned for the bottle instead of its own glass: the same
    # preshape and approach; the bottle's centre height, and a palm at least 1 cm off the bottle's surface
    from sim.grasping import GRASP_OBJECTS
    from sim.grasping import object_extent

    args = ("barrett", [4], np.zeros((1, 2)), [0.0], [True], [0])
    own, own_start = plan_trials(*args)
    same, _ = plan_trials(*args, objects=[4])
    bottle, bottle_start = plan_trials(*args, objects=[1])
    for a, b in zip(own, same):
        np.testing.assert_array_equal(a, b)
    for name in ("open_", "closed", "approach", "wrist", "volar"):
        np.testing.assert_array_equal(getattr(own, name), getattr(bottle, name))
    rise = GRASP_OBJECTS[1].rest_height_m - GRASP_OBJECTS[4].rest_height_m
    assert bottle.goal[0, 2] - own.goal[0, 2] == pytest.approx(rise, abs=1e-6)
    assert bottle_start[0, 2] - own_start[0, 2] == pytest.approx(rise, abs=1e-6)
    extent = float(object_extent(1, bottle.approach[0]))
    assert bottle.standoff[0] - extent >= 0.01 - 1e-6 > own.standoff[0] - extent   # the glass's: 2.5 mm off it


@pytest.fixture(scope="module", params=["barrett", "karlsruhe"])
def native_runs(request):
    hand = request.param
    return (hand, *native_run(hand))


def test_every_grasp_touches_and_lifts_on_native(native_runs):
    """Every grasp's object is touched by the hand (every hand-object pair collides and steps) and
    lifted 8 cm, the Barrett's Two-finger Thumb pinch of the 3 cm cube included (it never
    lifted before its preshape was spread). (The native / MJX-JAX equivalence of these trials:
    tests/test_grasp_equivalence_*.py.)"""
    hand, _, _, native = native_runs
    touched = (native.contacts[..., 0] > 0).any(-1) | (native.first_link >= 0)
    assert touched.all(), f"objects never touched: {np.array(GRASP_CLASSES)[~touched]}"
    dropped = {(hand, g) for g, lifted in zip(GRASP_CLASSES, native.lifted) if not lifted}
    assert not dropped, f"not lifted: {sorted(dropped)}"


def test_experiment_smoke(tmp_path):
    from experiments import grasp_mapping

    metrics = grasp_mapping.main(["--preset", "quick", "--out", str(tmp_path), "--grasps", "1,12",
                                  "--n-directions", "2", "--tilts-deg", "15", "--image-width", "64",
                                  "--image-height", "48"])
    assert metrics["backend"] == "native"
    assert metrics["trials"] == 2 * (1 + 2 + 1) * (2 + 1)
    assert set(metrics["success_rate"]) == {"barrett", "karlsruhe"}
    for name in ("report.md", "fig4.png", "success.png", "frames.png", "frame_barrett_1.png"):
        assert (tmp_path / name).exists()
