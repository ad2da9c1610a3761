"""`sim.rollout.mjx_step`: the same physics as `mjx.step`, with its LAPACK calls ordered."""
import re

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from mujoco import mjx

from sim.scenes import mjx_step
from tests.xla_level import run_module

# A damped, actuated pendulum (implicit damping) and a free ball that falls onto the plane and the
# pendulum, so the steps have contacts and the Newton solver runs. Spheres only: a small program.
_XML = """<mujoco>
  <option timestep="0.004" integrator="{integrator}" cone="elliptic"/>
  <worldbody>
    <geom type="plane" size="1 1 0.1"/>
    <body pos="0 0 0.3">
      <joint name="h1" axis="0 1 0" damping="0.5"/>
      <geom type="sphere" pos="0.2 0 0" size="0.05" mass="0.3"/>
    </body>
    <body pos="0.2 0.0 0.5"><freejoint/><geom type="sphere" size="0.03" mass="0.1"/></body>
  </worldbody>
  <actuator><position joint="h1" kp="5" kv="0.3"/></actuator>
</mujoco>"""


# ------------------------------------------------------------------ the order of LAPACK calls in XLA's program

_LAPACK = re.compile(r'custom_call_target="(?:lapack|blas)_\w+"')


def _computations(hlo: str) -> dict[str, dict[str, tuple[list[str], list[str], bool]]]:
    """Optimized HLO text -> {computation: {instruction: (operands, called computations, is LAPACK)}}."""
    comps, current = {}, None
    for line in hlo.splitlines():
        head = re.match(r"^(?:ENTRY )?%?([\w.\-]+) .*\{$", line)
        if head:
            current = comps.setdefault(head.group(1), {})
            continue
        inst = re.match(r"^\s+(?:ROOT )?%?([\w.\-]+) = (.*)$", line)
        if current is None or not inst:
            continue
        call = re.search(r"\s([a-z][\w\-]*)\(([^()]*)\)", " " + re.sub(r"/\*.*?\*/", "", inst.group(2)))
        operands = [o.strip().split(" ")[-1].lstrip("%") for o in call.group(2).split(",")] if call else []
        called = re.findall(r"(?:body|condition|to_apply|calls)=%?([\w.\-]+)", inst.group(2))
        current[inst.group(1)] = (operands, called, bool(_LAPACK.search(inst.group(2))))
    return comps


def unordered_lapack_pairs(hlo: str) -> int:
    """Pairs of LAPACK calls (or loops/calls containing one) in one computation with no data path
    between them: the pairs XLA:CPU may run at the same time."""
    comps = _computations(hlo)

    def has_lapack(name, seen=()):
        return name in comps and name not in seen and any(
            lap or any(has_lapack(c, seen + (name,)) for c in called) for _, called, lap in comps[name].values())

    pairs = 0
    for inst in comps.values():
        nodes = [n for n, (_, called, lap) in inst.items() if lap or any(has_lapack(c) for c in called)]
        ancestors = {}
        for n in nodes:
            stack, seen = list(inst[n][0]), set()
            while stack:
                x = stack.pop()
                if x in inst and x not in seen:
                    seen.add(x)
                    stack.extend(inst[x][0])
            ancestors[n] = seen
        pairs += sum(a not in ancestors[b] and b not in ancestors[a]
                     for i, a in enumerate(nodes) for b in nodes[i + 1:])
    return pairs


def test_mjx_step_is_mjx_step_with_every_lapack_call_ordered():
    """`check_mjx_step_orders_every_lapack_call` in a fresh process at XLA's default level: at the end
    of a long pytest worker this compile aborted once (tests/xla_level.py)."""
    assert "ORDERED" in run_module("tests.test_mjx_step")


def check_mjx_step_orders_every_lapack_call():
    """150 steps of 2 worlds with the ordered step and with MJX's own: the same state (float32
    round-off: the extra dependency may change how XLA fuses the same operations), the ball fell;
    and in XLA's optimized programs, MJX's `mjx.step` leaves the implicit
    integrator's Cholesky unordered against the other factorisations (the deadlock), `mjx_step`
    orders every LAPACK call."""
    model = mujoco.MjModel.from_xml_string(_XML.format(integrator="implicitfast"))
    mjx_model = mjx.put_model(model, impl="jax")
    template = mjx.make_data(model, impl="jax")
    data = jax.vmap(lambda q: template.replace(qpos=template.qpos.at[0].set(q), ctrl=template.ctrl + 0.3))(
        jnp.array([0.0, 0.4]))
    out, hlo = {}, {}
    for name, step in (("ours", mjx_step), ("mjx", mjx.step)):
        batched = jax.vmap(step, in_axes=(None, 0))
        rollout = jax.jit(lambda m, d: jax.lax.fori_loop(0, 150, lambda _, x: batched(m, x), d))  # noqa: B023
        compiled = rollout.lower(mjx_model, data).compile()
        out[name], hlo[name] = compiled(mjx_model, data), compiled.as_text()
    np.testing.assert_allclose(np.asarray(out["ours"].qpos), np.asarray(out["mjx"].qpos), atol=1e-4)
    np.testing.assert_allclose(np.asarray(out["ours"].qvel), np.asarray(out["mjx"].qvel), atol=1e-3)
    assert np.all(np.asarray(out["ours"].qpos)[:, 3] < 0.45)   # the ball's height: it fell
    assert len(_LAPACK.findall(hlo["ours"])) >= 3   # M, the solver's H, the integrator's M - h D
    assert unordered_lapack_pairs(hlo["mjx"]) > 0
    assert unordered_lapack_pairs(hlo["ours"]) == 0


def test_mjx_step_rejects_other_integrators():
    model = mujoco.MjModel.from_xml_string(_XML.format(integrator="RK4"))
    with pytest.raises(ValueError, match="integrator"):
        mjx_step(mjx.put_model(model, impl="jax"), mjx.make_data(model, impl="jax"))


if __name__ == "__main__":
    check_mjx_step_orders_every_lapack_call()
    print("ORDERED")
