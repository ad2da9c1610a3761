"""Native MuJoCo and MJX-JAX run the Karlsruhe hand's grasps alike (see `tests/grasp_equivalence.py`)."""
from tests.grasp_equivalence import check_in_fresh_process


def test_native_and_mjx_jax_agree_karlsruhe():
    """One trial per grasp class on both backends: same outcomes, links and object positions.

    Same criteria and the same float32-vs-float64 drift as the Barrett test; every grasp lifts on
    both backends. The 3 cm cube (class 9, Disc: fingertips of thumb, index, middle and ring) is
    balanced between the closing fingertips, and which way it tips is decided by that drift: both
    backends leave it at rest until the fingers close (1.2 s), then MuJoCo tips it about 14 degrees
    and pushes it 1 mm, MJX tips it about 27 degrees the other way and pushes it 30 mm (measured).
    Both then hold it with the same four fingertips, lift it to the same height and let it slip
    less than 1 mm, so it is held alike but ends about 35 mm apart: for it the end height, not the
    end position, is compared.

    Cost: one MJX program (6 worlds, 20-control-step chunks), compiled in a fresh process.
    """
    assert "EQUIVALENT" in check_in_fresh_process("karlsruhe", settle_anywhere=frozenset({9}))
