"""A bonded gel block swells through a strict mu ramp although its discrete equilibrium leaves
``J > 1`` between the energy's quadrature points at the base corners (issue 35).

The issue-35 benchmark block (1 x 1 x 0.2, bonded base, order-2 tetrahedra) failed its last step
at 53k and 108k unknowns: the displacement gradient is singular at the corners of the bonded
base, the corner elements' ``J`` (a cubic in each element) dips below 1 between the energy's
four points, and an admissibility test sampling more points than the energy stopped Newton
against that boundary (line search down to its minimum step, the tangent positive definite).
On this coarse mesh the same happens when the ramp goes on to the free stretch 2.0.
"""

import numpy as np
import ngsolve as ngs

from geometries import block
from ngsgel import EquilibriumProblem, FloryRehnerGel, Solid3D, ramp
from ngsgel.stability import free_matrix, negative_count

GEL = FloryRehnerGel(Nv=1e-2, chi=0.5)
BASE_CORNERS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)


def _volume_ratio_at(prob, rule_order):
    """``J`` at the points of the standard tetrahedron rule of ``rule_order`` in every element,
    with the points' coordinates."""
    u = prob.displacement
    J = prob.lam0 ** 3 * ngs.Det(prob.deformation_gradient(u))
    points = prob.mesh.MapToAllElements(ngs.IntegrationRule(ngs.TET, rule_order), ngs.VOL)
    X = np.asarray(ngs.CF((ngs.x, ngs.y, ngs.z))(points)).reshape(-1, 3)
    return np.asarray(J(points)).ravel(), X


def test_bonded_block_reaches_stretch_2_through_a_strict_ramp():
    mesh = block(lx=1, ly=1, lz=0.2, maxh=0.1).mesh
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=1.3, mu=GEL.mu_free(1.3), order=2)
    prob.fix("bottom")
    values = np.linspace(GEL.mu_free(1.3), GEL.mu_free(2.0), 11)[1:]
    result = ramp(prob, prob.mu, values=list(values), strict=True)

    assert result.converged and result.steps == 10 and prob.mu.Get() == values[-1]
    # a stable equilibrium: the free tangent is positive definite
    K = free_matrix(prob.tangent(prob.state), prob.free_mask)
    assert negative_count(K) == 0
    # inside the admissible set where the energy is evaluated (its rule: order 2 for p = 2)...
    J_energy, _ = _volume_ratio_at(prob, 2)
    assert J_energy.min() > 1.0
    # ...and outside it between those points, next to a corner of the bonded base: the case the
    # ramp must get through (if the mesher's elements no longer put it there, this test has lost
    # its point, not passed)
    J_dense, X = _volume_ratio_at(prob, 6)
    assert J_dense.min() < 1.0
    worst = X[np.argmin(J_dense)]
    assert np.min(np.linalg.norm(BASE_CORNERS - worst, axis=1)) < 0.02
