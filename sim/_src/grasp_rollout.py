"""Grasp trials (MAP §III, §IV-A) run in batches on one of three physics backends, behind one function.

`rollout_grasps(hand, params, object_start, backend=...)` steps B trials of one hand for
`n_control_steps()` control steps, with `controller_step` (jitted JAX) between control steps, and
returns `GraspOutcomes`. Backends:

* `native`: MuJoCo 4's `mujoco.batch.Batch` (the C engine on a thread pool; bit-identical to a serial
  `mj_step` loop). The controller reads `sensordata` (B, S) and writes the bound `ctrl` (B, U) between
  `Batch.rollout(10)` calls (10 substeps, recording `sensordata` for `peak_touch`); finished trials
  are no longer stepped. Per-trial parked objects get
  gravity compensation through `Batch.expand("body_gravcomp")`.
* `mjx-jax`: `mjx.put_model(m, impl="jax")`, `jax.vmap` over `mjx.Data` (and over the per-world
  `body_gravcomp`), `lax.scan` over control steps with the controller inside the scan, a nested
  `lax.scan` over the 10 physics substeps (recording `sensordata` for `peak_touch`). Runs on any JAX
  device and is differentiable. One compiled program per hand and batch size (`_mjx_chunk`: every
  object is in each hand's scene, so all grasps share it; its inputs are committed to the device so
  that the second call does not compile it again; `experiments/bench/bench_mjx.py` measures its
  compile and run times). Each physics step is `sim.scenes.mjx_step`, whose LAPACK calls cannot
  deadlock XLA:CPU's thread pool (`mjx.step`'s can: see the known problems in the docs). MJX keeps
  the `MJX_MAX_CONTACTS` (32) deepest candidate contacts per world; a rollout in which that many
  penetrate at once raises an error.
* `mjx-warp`: the same scan with `impl="warp"` (NVIDIA GPU, `warp-lang` and `mujoco-warp` installed).
  `naconmax` (contacts across all worlds) is sized from the batch; an overflow raises an error rather
  than silently dropping contacts.
* `auto`: `mjx-warp` where a CUDA GPU and Warp are present, else `native`.

Both MuJoCo and MJX compute `sensordata` in the forward pass of a step, from the state before that
step's integration, so every backend hands the controller the same quantities: the last substep's
readings, with each touch sensor at its peak over the control period's 10 substeps and each contact
sensor as read in the last substep that found a contact (`peak_touch`, the same function on every
backend); before the first step, no readings (`first_readings`).
"""
from __future__ import annotations

import functools
import importlib.util
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec
from mujoco import mjx
from mujoco.batch import Batch
from numpy.typing import ArrayLike

from lfd_common import as_array, check_choice, check_int
from lfd_common import batch_spec, check_mesh, pad_rows
from sim._src.grasp_objects import GRASP_CLASSES
from sim._src.grasp_strategy import (CONTROL_DT_S, DONE, ControllerState, TrialParams, controller_step,
    initial_state, n_control_steps)
from sim._src.robot_hands import (MJX_MAX_CONTACTS, SceneLayout, TIMESTEP_S, grasp_model, hand_joint_qpos,
    hand_spec, parked_position)
from sim._src.mjx_compat import contact_count, contact_distances
from sim._src.rollout import mjx_step

BACKENDS: tuple[str, ...] = ("auto", "native", "mjx-jax", "mjx-warp")
SUBSTEPS = int(round(CONTROL_DT_S / TIMESTEP_S))
LIFT_SUCCESS_M = 0.08          # object raised at least 8 of the 10 cm at the end of the hold
CONTACTS_PER_WORLD = 96        # mjx-warp naconmax per world


class GraspOutcomes(NamedTuple):
    """Per-trial results of `rollout_grasps` (numpy), B rows, L links (palm first).

    Attributes:
        lifted: (B,) bool: the object at least `LIFT_SUCCESS_M` (8 cm) above its start at the end of
            the hold (or of the horizon).
        lift_m: (B,) how far it was raised (m).
        object_end: (B, 3) its final position (world).
        palm_first: (B,) bool: the first touch was on the palm.
        first_link: (B,) int: the link of the first touch (-1: no contact).
        n_corrections: (B,) tactile corrections made (MAP §III).
        contacts: (B, L, 7) found flag, position (3) and normal (3, out of the object) per link in the
            object frame at the end of closing: the input of the virtual fingers (MAP §IV-A).
        slip_mm: (B,) object displacement in the palm frame during the hold (NaN if the hold was not
            reached).
        phase: (B,) final controller phase.
        qpos: (B, nq) the final state (for rendering).
    """

    lifted: np.ndarray
    lift_m: np.ndarray
    object_end: np.ndarray
    palm_first: np.ndarray
    first_link: np.ndarray
    n_corrections: np.ndarray
    contacts: np.ndarray
    slip_mm: np.ndarray
    phase: np.ndarray
    qpos: np.ndarray


def warp_status() -> str:
    """Whether the `mjx-warp` backend can run on this machine.

    Returns:
        "" if it can, else why not (a Python package missing, or no CUDA GPU visible to JAX).
    """
    missing = [m for m in ("warp", "mujoco_warp") if importlib.util.find_spec(m) is None]
    if missing:
        return f"python packages {', '.join(missing)} not installed (extra `gpu`)"
    if not any(d.platform == "gpu" for d in jax.devices()):
        return "no CUDA GPU visible to JAX"
    return ""


def resolve_backend(backend: str) -> str:
    """The backend `rollout_grasps` runs for `backend`, with "auto" resolved.

    Args:
        backend: "auto", "native", "mjx-jax" or "mjx-warp".

    Returns:
        `backend`, or for "auto" "mjx-warp" where a CUDA GPU and Warp are present, else "native".

    Raises:
        ValueError: an unknown backend, or "mjx-warp" where it is not available (`warp_status`).
    """
    backend = check_choice(backend, "backend", BACKENDS)
    if backend == "auto":
        return "mjx-warp" if not warp_status() else "native"
    if backend == "mjx-warp" and warp_status():
        raise ValueError(f"backend: 'mjx-warp' is not available on this machine: {warp_status()}")
    return backend


def initial_qpos(model: mujoco.MjModel, hand: str, layout: SceneLayout, params: TrialParams,
                 object_start: np.ndarray) -> np.ndarray:
    """The starting positions of B trials in the grasp scene.

    Args:
        model: the grasp scene of `hand` (`grasp_model`).
        hand: "barrett" or "karlsruhe".
        layout: the scene's layout.
        params: the plan of the trials (`plan_trials`).
        object_start: (B, 3) where each trial's object stands (world).

    Returns:
        (B, nq) qpos: the wrist at `params.start` with `params.wrist` angles, the fingers in the open
            preshape, the active object at `object_start`, the others parked.
    """
    b = params.goal.shape[0]
    shapes, inverse = np.unique(np.asarray(params.open_), axis=0, return_inverse=True)
    qpos = np.stack([hand_joint_qpos(model, hand, s) for s in shapes])[inverse.reshape(-1)]
    qpos[:, layout.wrist_qpos] = np.concatenate([params.start, params.wrist], -1)
    for k in range(len(GRASP_CLASSES)):   # over the six objects, not over trials
        adr = layout.object_qpos[k]
        active = np.asarray(params.obj) == k
        qpos[:, adr:adr + 3] = np.where(active[:, None], object_start, parked_position(k))
        qpos[:, adr + 3:adr + 7] = [1.0, 0.0, 0.0, 0.0]
    assert qpos.shape == (b, model.nq)
    return qpos


def object_gravcomp(model: mujoco.MjModel, layout: SceneLayout, obj: np.ndarray) -> np.ndarray:
    """Per-trial gravity compensation of the grasp scene's bodies.

    Args:
        model: the grasp scene (`grasp_model`).
        layout: its layout.
        obj: (B,) int: each trial's active object (index into `GRASP_CLASSES`).

    Returns:
        (B, nbody) body_gravcomp: 1 for the hand and for parked objects, 0 for each trial's active
            object.
    """
    grav = np.tile(model.body_gravcomp, (len(obj), 1))
    grav[:, layout.object_body] = 1.0
    grav[np.arange(len(obj)), layout.object_body[np.asarray(obj)]] = 0.0
    return grav


@functools.lru_cache(maxsize=None)
def grasp_scene(hand: str) -> tuple[mujoco.MjModel, SceneLayout]:
    """The grasp scene of `hand`, compiled once per process (`grasp_model`, cached).

    Args:
        hand: "barrett" or "karlsruhe".

    Returns:
        (model, layout), shared by every caller: do not modify the model.

    Raises:
        ValueError: an unknown hand.
    """
    model, layout = grasp_model(hand)
    return model, layout


@functools.lru_cache(maxsize=None)
def jitted_controller(hand: str) -> Callable:
    """`controller_step` jitted for the sensor layout of `hand`'s grasp scene, once per process.

    Args:
        hand: "barrett" or "karlsruhe".

    Returns:
        A function (state, sensordata, params) -> (state, ctrl).
    """
    _, layout = grasp_scene(hand)
    return jax.jit(functools.partial(controller_step, layout=layout))


def _check_inputs(hand: str, params: TrialParams, object_start) -> tuple[TrialParams, np.ndarray]:
    spec = hand_spec(hand)
    b = np.shape(params.goal)[0]
    if b < 1:
        raise ValueError("params: empty batch")
    fields = {}
    for name, value in params._asdict().items():
        arr = np.asarray(value)
        if arr.shape[:1] != (b,):
            raise ValueError(f"params.{name}: expected {b} rows, got shape {arr.shape}")
        if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
            raise ValueError(f"params.{name}: contains NaN or infinite values")
        fields[name] = arr
    if fields["open_"].shape[1] != len(spec.dofs):
        raise ValueError(f"params.open_: expected {len(spec.dofs)} hand DoF for {hand}, got {fields['open_'].shape[1]}")
    object_start = as_array(object_start, "object_start", shape=(b, 3))
    return TrialParams(**fields), object_start


def trial_outcomes(state: ControllerState, qpos: np.ndarray, layout: SceneLayout, object_start: np.ndarray,
                   obj: np.ndarray) -> GraspOutcomes:
    """The outcomes of B trials from the controller's final state and the final positions.

    Args:
        state: the controller state after the last control step.
        qpos: (B, nq) the final positions.
        layout: the grasp scene's layout.
        object_start: (B, 3) where each object started (world).
        obj: (B,) int: each trial's active object (index into `GRASP_CLASSES`).

    Returns:
        The `GraspOutcomes`: an object counts as lifted when it is `LIFT_SUCCESS_M` above its start
            at the end of the hold (or of the horizon, for a trial that did not finish).
    """
    state = jax.tree.map(np.asarray, state)
    adr = layout.object_qpos[obj]
    object_now = np.take_along_axis(qpos, adr[:, None] + np.arange(3), axis=1)
    done = state.phase == DONE
    end = np.where(done[:, None], state.end_obj, object_now)
    lift = end[:, 2] - object_start[:, 2]
    return GraspOutcomes(
        lifted=lift >= LIFT_SUCCESS_M, lift_m=lift, object_end=end, palm_first=state.palm_first,
        first_link=state.first_link, n_corrections=state.n_corr, contacts=state.grasp_contacts,
        slip_mm=np.where(done, 1e3 * state.slip_m, np.nan), phase=state.phase, qpos=qpos)


def rollout_grasps(hand: str, params: TrialParams, object_start: ArrayLike, backend: str = "auto",
                   nthread: int = 0, *, mesh: Mesh | None = None) -> GraspOutcomes:
    """Run B grasp trials of `hand` on a physics backend (MAP §III strategy, MAP §IV-A evaluation).

    Args:
        hand: "barrett" or "karlsruhe".
        params: the plan of the trials (`plan_trials`).
        object_start: (B, 3) where each trial's object really stands.
        backend: "auto", "native", "mjx-jax" or "mjx-warp" (see the module docstring).
        nthread: `native` threads (0: all).
        mesh: a `jax.sharding.Mesh` of this process's devices (MJX backends; None: one device): the
            worlds are padded to the mesh with copies of trial 0 and split over its devices, the
            outcomes cut back to B; they equal the one-device outcomes.

    Returns:
        The `GraspOutcomes` of the B trials.

    Raises:
        ValueError: bad input naming the argument (`params.<field>` for a plan of the wrong shape or
            with non-finite values), an unavailable backend, or a `mesh` with the native backend.
        RuntimeError: an MJX contact buffer overflowed (contacts would have been dropped).
    """
    mesh = check_mesh(mesh)
    hand = hand_spec(hand).name
    backend = resolve_backend(backend)
    nthread = check_int(nthread, "nthread", min_value=0, max_value=1024)
    params, object_start = _check_inputs(hand, params, object_start)
    if backend == "native":
        if mesh is not None:
            raise ValueError("mesh: the native backend runs on host threads; shard worlds with an MJX backend")
        return _rollout_native(hand, params, object_start, nthread)
    impl = "jax" if backend == "mjx-jax" else "warp"
    if mesh is None:
        return _rollout_mjx(hand, params, object_start, impl)
    b = object_start.shape[0]
    *fields, start = pad_rows((*params, object_start), -(-b // mesh.size) * mesh.size)
    out = _rollout_mjx(hand, TrialParams(*fields), start, impl, mesh)
    return GraspOutcomes(*(a[:b] for a in out))


def peak_touch(substeps: np.ndarray | jax.Array, layout: SceneLayout) -> np.ndarray | jax.Array:
    """The controller's sensor readings from the substeps of one control period (numpy or jax).

    The last substep's readings, except: each touch sensor at its peak over the K substeps, and each
    (link, object) contact sensor (found, position, normal: the contact c of MAP §III's correction)
    as read in the last substep that found a contact (the last substep's, found 0, if none did), so a
    contact felt in any substep comes with its own position. A light object pushed by the hand touches
    it intermittently: one sample per control period misses most touches, and a peak `found` beside
    the last substep's position would report a contact without a position.

    Args:
        substeps: (B, K, S) sensordata of the K substeps, numpy or jax.
        layout: where the touch and contact sensors are (`SceneLayout`).

    Returns:
        (B, S) readings, of `substeps`' array type.
    """
    xp = np if isinstance(substeps, np.ndarray) else jnp
    k = substeps.shape[1]
    cols = layout.contact.ravel()[:, None] + np.arange(7)                       # (C, 7) contact blocks
    found = substeps[:, :, layout.contact.ravel()] > 0                          # (B, K, C)
    when = k - 1 - xp.argmax(found[:, ::-1], axis=1)                            # (B, C) last substep found
    blocks = xp.take_along_axis(substeps[:, :, cols], when[:, None, :, None], axis=1)[:, 0]   # (B, C, 7)
    idx = np.concatenate([layout.touch, cols.ravel()])
    values = xp.concatenate([substeps[:, :, layout.touch].max(1), blocks.reshape(blocks.shape[0], -1)], -1)
    if xp is np:
        out = substeps[:, -1].copy()
        out[:, idx] = values
        return out
    return substeps[:, -1].at[:, idx].set(values)


def native_start(hand: str, params: TrialParams, object_start: np.ndarray, nthread: int) -> tuple:
    """The `native` backend's worlds at the start of the trials, for a caller that steps them itself.

    Args:
        hand: "barrett" or "karlsruhe".
        params: the plan of the B trials (checked by the caller).
        object_start: (B, 3) where each trial's object stands.
        nthread: `mujoco.batch.Batch` threads (0: all).

    Returns:
        (model, layout, batch, controller, controller state, first sensor readings (B, S), ctrl view
            (B, U)): the native rollout steps exactly these.
    """
    model, layout = grasp_scene(hand)
    b = params.goal.shape[0]
    batch = Batch(model, nsim=b, nthread=nthread)
    batch.reset(stage=mujoco.mjtStage.mjSTAGE_NONE)
    batch.bind("qpos")[:] = initial_qpos(model, hand, layout, params, object_start)
    batch.expand("body_gravcomp")[:] = object_gravcomp(model, layout, params.obj)
    return (model, layout, batch, jitted_controller(hand), initial_state(params, layout.n_links),
            first_readings(b, model), batch.bind("ctrl"))


def _rollout_native(hand: str, params: TrialParams, object_start: np.ndarray, nthread: int) -> GraspOutcomes:
    model, layout, batch, control, state, sensordata, ctrl_view = native_start(hand, params, object_start, nthread)
    b = params.goal.shape[0]
    for _ in range(n_control_steps()):
        state, ctrl = control(state, jnp.asarray(sensordata, jnp.float32), params)
        ctrl_view[:] = np.asarray(ctrl)
        active = np.asarray(state.phase) != DONE
        if not active.any():
            break
        record = batch.rollout(SUBSTEPS, record=("sensordata",), ids=active)["sensordata"]  # (n, SUBSTEPS, S)
        sensordata[active] = peak_touch(record, layout)
    return trial_outcomes(state, np.array(batch.bind("qpos")), layout, object_start, params.obj)


CHUNK = 20  # control steps per compiled scan (see `_mjx_chunk`)


def first_readings(n_worlds: int, model: mujoco.MjModel) -> np.ndarray:
    """The sensor readings the controller's first step sees on every backend: none (zeros).

    Every trial starts with the hand in the air, clear of the object, so there is nothing to feel, and
    the first control step only starts the approach (it reads no pose). Starting from zeros instead of
    a forward pass keeps the MJX backends at one compiled program per hand (a forward pass is a
    second program about as large as a step).

    Args:
        n_worlds: B, the number of trials.
        model: the grasp scene.

    Returns:
        (B, S) zeros, S = `model.nsensordata`.
    """
    return np.zeros((n_worlds, model.nsensordata))


@functools.lru_cache(maxsize=None)
def _mjx_chunk(hand: str, impl: str):
    """The jitted chunk of the MJX backends, the only program they compile per hand and batch size.

    chunk(mjx model, gravcomp (B, nbody), data, sensors, state, params) -> (data, sensors, state,
    deepest) after `CHUNK` control steps: a `lax.scan` over control steps (controller inside), each a
    `lax.scan` over the `SUBSTEPS` physics steps of one vmapped step (`mjx_step` on
    MJX-JAX, whose LAPACK calls cannot deadlock XLA:CPU; `mjx.step` on Warp). sensors (B, S): the
    controller's input (`peak_touch` of the substeps' sensordata); deepest (B,) int: the most
    penetrating contacts a world had at once (`_penetrating`). The horizon runs as up to
    n_control_steps() / CHUNK calls of this one program, stopping early once every trial is done.
    """
    _, layout = grasp_scene(hand)
    control = functools.partial(controller_step, layout=layout)

    def chunk(mjx_model, gravcomp, data, sensors, state, params):
        axes = jax.tree.map(lambda _: None, mjx_model).tree_replace({"body_gravcomp": 0})
        models = mjx_model.tree_replace({"body_gravcomp": gravcomp})
        step = jax.vmap(mjx_step if impl == "jax" else mjx.step, in_axes=(axes, 0))

        def substep(carry, _):
            data, deepest = carry
            data = step(models, data)
            return (data, jnp.maximum(deepest, _penetrating(data, impl))), data.sensordata

        def control_step(carry, _):
            data, sensors, state, deepest = carry
            state, ctrl = control(state, sensors, params)
            data = data.replace(ctrl=ctrl)
            (data, deepest), record = jax.lax.scan(substep, (data, deepest), None, length=SUBSTEPS)
            return (data, peak_touch(jnp.swapaxes(record, 0, 1), layout), state, deepest), None

        deepest = jnp.zeros(sensors.shape[0], jnp.int32)
        carry, _ = jax.lax.scan(control_step, (data, sensors, state, deepest), None, length=CHUNK)
        return carry

    return jax.jit(chunk)


def _penetrating(data, impl: str) -> jax.Array:
    """(B,) int: contacts with negative distance per world on MJX-JAX (zeros on Warp, which counts
    contacts itself). MJX-JAX keeps the `MJX_MAX_CONTACTS` deepest candidate contacts of a world; when
    that many penetrate at once, a deeper one may have been dropped."""
    if impl != "jax":
        return jnp.zeros(data.qpos.shape[0], jnp.int32)
    return jnp.sum(contact_distances(data) < 0, axis=-1).astype(jnp.int32)


def _contact_count(data) -> jax.Array:
    """Contacts in use across all worlds (Warp's `nacon`), or -1 where the implementation has no count."""
    nacon = contact_count(data)
    return jnp.asarray(-1 if nacon is None else jnp.max(nacon))


def mjx_template(model: mujoco.MjModel, impl: str, n_worlds: int):
    """The `mjx.Data` template of one world (`impl` "jax" or "warp"; Warp sizes contacts for the batch)."""
    if impl == "warp":
        return mjx.make_data(model, impl="warp", naconmax=CONTACTS_PER_WORLD * n_worlds,
                             njmax=4 * CONTACTS_PER_WORLD)
    return mjx.make_data(model, impl="jax")


def _rollout_mjx(hand: str, params: TrialParams, object_start: np.ndarray, impl: str, mesh=None) -> GraspOutcomes:
    model, layout = grasp_scene(hand)
    b = params.goal.shape[0]
    mjx_model = mjx.put_model(model, impl=impl)
    qpos = jnp.asarray(initial_qpos(model, hand, layout, params, object_start), jnp.float32)
    grav = jnp.asarray(object_gravcomp(model, layout, params.obj), jnp.float32)
    jparams = TrialParams(*[jnp.asarray(x) for x in params])
    data = jax.tree.map(lambda x: jnp.broadcast_to(x, (b, *jnp.shape(x))), mjx_template(model, impl, b))
    data = data.replace(qpos=qpos)
    sensors = jnp.asarray(first_readings(b, model), jnp.float32)
    state = initial_state(jparams, layout.n_links)
    # committed to the device like the chunk's outputs, so the second call does not compile again for
    # inputs that differ only in being uncommitted (a compilation costs far more than a chunk's run)
    # (with a mesh: the model replicated, every world's arrays split by world; jit partitions the chunk)
    one = jax.devices()[0] if mesh is None else NamedSharding(mesh, PartitionSpec())
    mjx_model = jax.device_put(mjx_model, one)
    grav, data, sensors, state, jparams = jax.device_put(
        (grav, data, sensors, state, jparams), one if mesh is None else NamedSharding(mesh, batch_spec(mesh)))
    chunk, deepest = _mjx_chunk(hand, impl), 0
    for _ in range(n_control_steps() // CHUNK):  # chunks of one compiled scan (see `_mjx_chunk`)
        data, sensors, state, chunk_deepest = chunk(mjx_model, grav, data, sensors, state, jparams)
        deepest = max(deepest, int(np.max(chunk_deepest)))
        if np.all(np.asarray(state.phase) == DONE):
            break
    qpos_end, nacon = data.qpos, _contact_count(data)
    if impl == "warp" and int(nacon) >= CONTACTS_PER_WORLD * b:
        raise RuntimeError(f"mjx-warp: contact buffer full ({int(nacon)} contacts for {b} worlds); contacts "
                           "were dropped. Raise CONTACTS_PER_WORLD.")
    if deepest >= MJX_MAX_CONTACTS:
        raise RuntimeError(f"mjx-jax: {deepest} contacts penetrated at once in one world, the most MJX keeps "
                           "(MJX_MAX_CONTACTS in sim/_src/robot_hands.py); deeper ones may have been dropped. "
                           "Raise it.")
    return trial_outcomes(state, np.asarray(qpos_end, np.float64), layout, object_start, params.obj)
