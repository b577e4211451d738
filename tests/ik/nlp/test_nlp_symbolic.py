from pathlib import Path

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.kinematics.symbolic import SymbolicFK, fk_function

DATA = Path(__file__).parent / "data"
PLANAR = Path(__file__).parents[2] / "data" / "planar3r.yaml"


@pytest.mark.parametrize("path", [DATA / "ur5e.yaml", DATA / "panda.yaml", DATA / "twoarm.yaml",
                                  PLANAR, "so101", "wx250s", "torso"])
def test_casadi_fk_equals_model_fk_for_every_frame(path):
    arm = load_arm(path)
    rng = np.random.default_rng(3)
    qs = arm.sample(rng, 20)
    for frame in arm.frame_names:
        f = fk_function(arm, frame)
        for q in qs:
            np.testing.assert_allclose(np.array(f(q)), arm.fk(q, frame), atol=1e-12)


def test_shared_chain_and_jacobian(ur5e):
    import casadi as ca

    sym = SymbolicFK(ur5e)
    _, pos = sym.frame(None)
    jac = ca.Function("j", [sym.q], [ca.jacobian(pos, sym.q)])
    q = ur5e.sample(np.random.default_rng(0))
    # the derivative of the symbolic position is the linear block of the geometric Jacobian
    np.testing.assert_allclose(np.array(jac(q)), ur5e.jacobian(q)[:3], atol=1e-10)
    # a joint frame is built once and reused
    assert sym.joint_frame(2) is sym.joint_frame(2)
