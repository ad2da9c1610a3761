"""Virtual fingers (MAP §IV-A): contacts -> virtual fingers, matching between a robot and a human grasp.

A virtual finger is a group of real fingers acting in unison; the palm is always one on its own.
Entities are the palm and each finger with at least one contact; each has the mean position and the
mean (unit) normal of its contacts, in the object frame, normals pointing out of the object. Fingers
whose normals are within `max_angle_deg` of each other are grouped (single linkage: transitive
closure of the "close normals" graph), so fingers pressing from the same side form one virtual finger.
A virtual finger's pose is the mean of its member fingers' positions and normals.

Matching: with n_r robot and n_h human virtual fingers, the min(n_r, n_h) pairs are chosen that
minimise the summed position distance (all injective assignments enumerated, vectorised over trials;
E <= 6 entities). The errors are the mean position distance (mm) and the mean angle between normals
(degrees) over the matched pairs: a lower bound when the numbers differ, as in the paper.

Shapes: B trials, E entities (palm first, then fingers), K contacts.
"""
from __future__ import annotations

import itertools
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from sim._src.human_hand import FINGERS as HUMAN_FINGERS
from sim._src.human_grasps import grasp_contacts

N_ENTITIES = 6          # palm + up to five fingers
MAX_ANGLE_DEG = 45.0


class VirtualFingers(NamedTuple):
    """B sets of at most E virtual fingers (or entities), in the object frame (MAP §IV-A).

    Attributes:
        valid: (B, E) bool: the slot holds a virtual finger.
        pos: (B, E, 3) mean contact positions.
        normal: (B, E, 3) mean unit contact normals, out of the object.
    """

    valid: jax.Array
    pos: jax.Array
    normal: jax.Array


class VFErrors(NamedTuple):
    """The virtual-finger errors of B robot grasps against a human grasp (MAP §IV-A, Fig. 4).

    Attributes:
        position_mm: (B,) mean matched position error (mm, NaN if nothing matched).
        orientation_deg: (B,) mean matched orientation error (degrees, NaN if nothing matched).
        n_matched: (B,) matched pairs.
        n_robot: (B,) robot virtual fingers.
        n_human: (B,) human virtual fingers.
    """

    position_mm: jax.Array
    orientation_deg: jax.Array
    n_matched: jax.Array
    n_robot: jax.Array
    n_human: jax.Array


def _normalize(v: jax.Array) -> jax.Array:
    return v / jnp.maximum(jnp.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


@jax.jit
def entities_from_links(contacts: jax.Array, link_entity: jax.Array) -> VirtualFingers:
    """Per-link contact records reduced to entities: the palm and each finger with a contact.

    Args:
        contacts: (B, L, 7) per link: found, position (3), normal (3) in the object frame.
        link_entity: (L,) int: 0 palm, k finger k (< E).

    Returns:
        The entities (B, E): mean position and mean unit normal of each entity's contacts.
    """
    found = contacts[..., 0] > 0                                                  # (B, L)
    onehot = (link_entity[:, None] == jnp.arange(N_ENTITIES)).astype(contacts.dtype)  # (L, E)
    w = found.astype(contacts.dtype)[..., None] * onehot                           # (B, L, E)
    count = w.sum(1)                                                               # (B, E)
    pos = jnp.einsum("ble,blc->bec", w, contacts[..., 1:4]) / jnp.maximum(count, 1)[..., None]
    normal = _normalize(jnp.einsum("ble,blc->bec", w, contacts[..., 4:7]))
    return VirtualFingers(count > 0, pos, normal)


@jax.jit
def group_virtual_fingers(ent: VirtualFingers, max_angle_deg: float = MAX_ANGLE_DEG) -> VirtualFingers:
    """Group finger entities with close normals into virtual fingers (MAP §IV-A).

    Fingers (index >= 1) whose normals are within `max_angle_deg` of each other are grouped by single
    linkage; each group is stored at its lowest member index; the palm (index 0) stays alone.

    Args:
        ent: entities (B, E) (`entities_from_links`).
        max_angle_deg: the largest angle between normals of fingers acting in unison.

    Returns:
        The virtual fingers (B, E): the mean of their members' positions and normals.
    """
    e = ent.valid.shape[-1]
    cos = jnp.einsum("bic,bjc->bij", ent.normal, ent.normal)
    fingers = jnp.arange(e) >= 1
    both = ent.valid[:, :, None] & ent.valid[:, None, :] & fingers[:, None] & fingers[None, :]
    adj = (both & (cos >= jnp.cos(jnp.radians(max_angle_deg)))) | (jnp.eye(e, dtype=bool) & ent.valid[:, :, None])
    for _ in range(3):  # 2^3 >= E - 1 path lengths: transitive closure
        adj = adj | (jnp.einsum("bij,bjk->bik", adj.astype(jnp.int32), adj.astype(jnp.int32)) > 0)
    root = jnp.argmax(adj, axis=-1)                                 # lowest connected index (B, E)
    member = (root[:, :, None] == jnp.arange(e)) & ent.valid[:, :, None]   # (B, member, group)
    w = member.astype(ent.pos.dtype)
    count = w.sum(1)
    pos = jnp.einsum("bmg,bmc->bgc", w, ent.pos) / jnp.maximum(count, 1)[..., None]
    normal = _normalize(jnp.einsum("bmg,bmc->bgc", w, ent.normal))
    return VirtualFingers(count > 0, pos, normal)


_PERMS = np.array(list(itertools.permutations(range(N_ENTITIES))))   # (720, E)


@jax.jit
def match_virtual_fingers(robot: VirtualFingers, human: VirtualFingers) -> VFErrors:
    """Match robot to human virtual fingers and measure their errors (MAP §IV-A).

    The min(n_r, n_h) pairs that minimise the summed position distance are chosen (all injective
    assignments enumerated); the errors are a lower bound when the counts differ, as in the paper.

    Args:
        robot: (B, E) the robot's virtual fingers.
        human: (B, E) the human's.

    Returns:
        The `VFErrors`.
    """
    perms = jnp.asarray(_PERMS)
    h_valid = human.valid[:, perms]                                      # (B, P, E)
    h_pos = human.pos[:, perms]                                          # (B, P, E, 3)
    h_nrm = human.normal[:, perms]
    pair = robot.valid[:, None, :] & h_valid                             # (B, P, E)
    dist = jnp.linalg.norm(robot.pos[:, None] - h_pos, axis=-1)          # (B, P, E)
    n_pairs = pair.sum(-1)
    cost = jnp.where(pair, dist, 0.0).sum(-1) - 1e3 * n_pairs            # more pairs first, then distance
    best = jnp.argmin(cost, axis=-1)
    pair_b, dist_b = _at(pair, best), _at(dist, best)
    cos = jnp.clip(jnp.sum(robot.normal * _at(h_nrm, best), -1), -1.0, 1.0)
    n = pair_b.sum(-1)
    safe_n = jnp.maximum(n, 1)
    pos_err = jnp.where(n > 0, 1e3 * jnp.where(pair_b, dist_b, 0.0).sum(-1) / safe_n, jnp.nan)
    ang_err = jnp.where(n > 0, jnp.degrees(jnp.where(pair_b, jnp.arccos(cos), 0.0)).sum(-1) / safe_n, jnp.nan)
    return VFErrors(pos_err, ang_err, n, robot.valid.sum(-1), human.valid.sum(-1))


def _at(x: jax.Array, best: jax.Array) -> jax.Array:
    """x (B, P, E, ...) at permutation `best` (B,) -> (B, E, ...)."""
    return jnp.take_along_axis(x, best.reshape((-1, 1) + (1,) * (x.ndim - 2)), axis=1)[:, 0]


def human_entities(grasp: int) -> VirtualFingers:
    """The entities of a human reference grasp: the palm (incl. thenar and metacarpals) and five fingers.

    Args:
        grasp: the grasp class (`GRASP_CLASSES`).

    Returns:
        The entities (1, E), from `grasp_contacts` (object frame, normals out of the object).

    Raises:
        ValueError: an unknown grasp class.
    """
    c = grasp_contacts(grasp)
    entity = np.array([next((k + 1 for k, f in enumerate(HUMAN_FINGERS) if part.startswith(f)), 0)
                       for part in c.parts], dtype=np.int32)
    records = np.concatenate([np.ones((len(entity), 1)), c.positions, c.normals], -1)[None]
    return entities_from_links(jnp.asarray(records, jnp.float32), jnp.asarray(entity))


def vf_errors(contacts: np.ndarray, link_finger: np.ndarray, human: VirtualFingers) -> VFErrors:
    """The virtual-finger errors of B robot grasps against one human grasp (MAP §IV-A, Fig. 4).

    Args:
        contacts: (B, L, 7) robot contact records (`GraspOutcomes.contacts`).
        link_finger: (L,) 0 palm, k finger k (`HandSpec.link_finger`).
        human: the human grasp's entities (1, E) (`human_entities`).

    Returns:
        The `VFErrors`, as numpy arrays.
    """
    robot = group_virtual_fingers(entities_from_links(jnp.asarray(contacts, jnp.float32), jnp.asarray(link_finger)))
    b = contacts.shape[0]
    human_vf = group_virtual_fingers(human)
    human_b = VirtualFingers(*[jnp.broadcast_to(x, (b,) + x.shape[1:]) for x in human_vf])
    return VFErrors(*[np.asarray(x) for x in match_virtual_fingers(robot, human_b)])
