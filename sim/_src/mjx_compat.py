"""Every use of MJX's private data fields, in one place, checked against the MJX versions it was written for.

`mjx.Data` keeps implementation-specific arrays in `data._impl` (`DataJAX` for `impl="jax"`, a Warp
data class for `impl="warp"`), which is not public API and may change between MJX releases. `sim`
needs four of them:
* the mass matrix M (MJX-JAX `_impl.M`, dense (nv, nv) for small models), which `mjx_step`
  reads after the forward pass and writes back before integrating (to order the LAPACK calls);
* the signed distance of every candidate contact (MJX-JAX `_impl.contact.dist`, (ncon,) per world,
  negative when penetrating), for the contact-budget check of `grasp_rollout` and the contacts the
  task controller reads (`sim.robot.TaskSim` on MJX);
* the geom pair of every candidate contact (MJX-JAX `_impl.contact.geom`, (ncon, 2)), for the same;
* the number of contacts in use (MJX-Warp `_impl.nacon`), for the contact-buffer check.

Importing this module warns when the installed `mujoco-mjx` is outside `SUPPORTED_MJX`; a missing
field raises a `RuntimeError` naming it and the installed version. `tests/test_mjx_compat.py` pins
what the fields mean (M against MuJoCo's `mj_fullM`, contact distances against `mj_forward`'s).
"""
from __future__ import annotations

import importlib.metadata
import warnings

import jax
from mujoco import mjx

__all__ = ["SUPPORTED_MJX", "contact_count", "contact_distances", "contact_geoms", "mass_matrix", "mjx_version",
           "with_mass_matrix"]

SUPPORTED_MJX = ((3, 17), (4, 0))  # [first, last): the releases these field names were checked with


def mjx_version() -> tuple[int, ...]:
    """The installed mujoco-mjx release as integers, e.g. (3, 17, 0)."""
    text = importlib.metadata.version("mujoco-mjx")
    return tuple(int(p) for p in text.split(".")[:3] if p.isdigit())


def _check_version() -> None:
    lo, hi = SUPPORTED_MJX
    if not lo <= mjx_version()[:2] < hi:
        warnings.warn(f"sim: mujoco-mjx {'.'.join(map(str, mjx_version()))} is outside the range "
                      f"{'.'.join(map(str, lo))} <= v < {'.'.join(map(str, hi))} that sim/_src/mjx_compat.py was written "
                      "for (it reads private MJX fields); run tests/test_mjx_compat.py", RuntimeWarning, stacklevel=2)


_check_version()


def _field(data: mjx.Data, path: str):
    obj = data
    for name in path.split("."):
        try:
            obj = getattr(obj, name)
        except AttributeError as err:
            raise RuntimeError(f"data: mjx.Data has no private field {path!r} in mujoco-mjx "
                               f"{'.'.join(map(str, mjx_version()))} (sim/_src/mjx_compat.py needs updating)") from err
    return obj


def mass_matrix(data: mjx.Data) -> jax.Array:
    """MJX-JAX's mass matrix M of `data` as computed by the last forward pass (dense (nv, nv) for
    small models, MuJoCo's sparse layout (nM,) otherwise; batched like `data`)."""
    return _field(data, "_impl.M")


def with_mass_matrix(data: mjx.Data, mass: jax.Array) -> mjx.Data:
    """`data` with its MJX-JAX mass matrix replaced by `mass` (the matrix the integrators factorise)."""
    _field(data, "_impl.M")
    return data.tree_replace({"_impl.M": mass})


def contact_distances(data: mjx.Data) -> jax.Array:
    """MJX-JAX: the signed distance (..., ncon) of every candidate contact (negative = penetrating)."""
    return _field(data, "_impl.contact.dist")


def contact_geoms(data: mjx.Data) -> jax.Array:
    """MJX-JAX: the geom ids (..., ncon, 2) of every candidate contact (`contact_distances` says which touch)."""
    return _field(data, "_impl.contact.geom")


def contact_count(data: mjx.Data) -> jax.Array | None:
    """MJX-Warp: the contacts in use across all worlds (`nacon`); None for implementations without it."""
    return getattr(getattr(data, "_impl", None), "nacon", None)
