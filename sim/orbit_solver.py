"""One periodic orbit on the shooting map: Newton at a fixed parameter, the pseudo-arclength
corrector and tangent (:class:`Solver`), Floquet stability of a converged orbit (:func:`orbit_point`).

The multipliers are the eigenvalues of the monodromy matrix, the map's finite-difference Jacobian
at the orbit (:meth:`rigtools.sim.orbit_map.PeriodMap.jacobian`), restricted to the blades and
the coil (never the force control's drive correction).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from rigtools.sim.branch_points import BranchPoint
from rigtools.sim.orbit_map import ContinuationError, Forcing, PeriodMap
from rigtools.sim.vibro_impact import SimulationInputError


@dataclass
class Solution:
    """A converged orbit with what the next step needs."""

    y: np.ndarray
    lam: float
    fy: np.ndarray
    jac: np.ndarray  # dPhi/dy at the solution (the monodromy matrix)
    dpar: np.ndarray
    data: np.ndarray
    iterations: int


class Solver:
    """Newton (fixed parameter) and pseudo-arclength correctors on one :class:`PeriodMap`."""

    def __init__(self, pmap: PeriodMap, param: str, forcing: Forcing, y_scale: float, lam_scale: float):
        self.pmap = pmap
        self.param = param
        self.forcing = forcing
        self.Y = y_scale
        self.L = lam_scale
        self.tol = 1e-9
        self.max_iter = 12

    def at(self, lam: float) -> Forcing:
        return self.forcing.with_value(self.param, lam)

    def scaled(self, y: np.ndarray, lam: float) -> np.ndarray:
        return np.concatenate([y / self.Y, [lam / self.L]])

    def finish(self, y: np.ndarray, lam: float, iterations: int) -> Solution:
        p = self.at(lam)
        fy, data = self.pmap.flow(y, p)
        data = data.copy()
        fy, jac, dpar = self.pmap.jacobian(y, p, self.param, fy=fy)
        assert dpar is not None
        return Solution(y, lam, fy, jac, dpar, data, iterations)

    def fixed(
        self, y: np.ndarray, lam: float, jac: np.ndarray | None = None
    ) -> tuple[np.ndarray, int] | None:
        """Newton on ``Phi(y) - y = 0`` at a fixed parameter; ``None`` if it does not converge
        (an integration that diverges on the way included: a Newton step that ran away)."""
        p = self.at(lam)
        eye = np.eye(y.size)
        for it in range(1, self.max_iter + 1):
            try:
                if jac is None or it % 4 == 0:
                    fy, jac, _ = self.pmap.jacobian(y, p)
                else:
                    fy = self.pmap.flow(y, p)[0]
            except SimulationInputError:
                return None
            r = fy - y
            try:
                dy = np.linalg.solve(jac - eye, -r)
            except np.linalg.LinAlgError:
                return None
            y = y + dy
            if not np.all(np.isfinite(y)):
                return None
            if np.linalg.norm(dy) <= self.tol * self.Y and np.linalg.norm(r) <= 1e3 * self.tol * self.Y:
                return y, it
        return None

    def arclength(
        self,
        u_pred: np.ndarray,
        tangent: np.ndarray,
        jac: np.ndarray | None,
        dpar: np.ndarray | None,
        full: bool = False,
    ) -> tuple[np.ndarray, float, int] | None:
        """Chord Newton on ``Phi(y, lam) - y = 0``, ``tangent . (u - u_pred) = 0`` starting from
        the Jacobian given (refreshed after 4 slow iterations); ``None`` if no convergence."""
        u = u_pred.copy()
        m = u.size - 1
        eye = np.eye(m)
        fresh = False
        prev_rate = math.inf
        ratio = 0.0
        for it in range(1, self.max_iter + 1):
            y, lam = u[:m] * self.Y, u[m] * self.L
            p = self.at(lam)
            try:
                if full or jac is None or dpar is None or (it > 1 and not fresh and (ratio > 0.3 or it >= 5)):
                    fy, jac, dpar_new = self.pmap.jacobian(y, p, self.param)
                    assert dpar_new is not None
                    dpar = dpar_new
                    fresh = True
                else:
                    fy = self.pmap.flow(y, p)[0]
            except SimulationInputError:
                return None
            r = np.concatenate([(fy - y) / self.Y, [tangent @ (u - u_pred)]])
            a = np.zeros((m + 1, m + 1))
            a[:m, :m] = jac - eye
            a[:m, m] = dpar * self.L / self.Y
            a[m] = tangent
            try:
                du = np.linalg.solve(a, -r)
            except np.linalg.LinAlgError:
                return None
            rate = float(np.linalg.norm(du))
            u = u + du
            if not np.all(np.isfinite(u)):
                return None
            if rate <= self.tol:
                return u[:m] * self.Y, u[m] * self.L, it
            ratio = rate / prev_rate if math.isfinite(prev_rate) else 0.0
            prev_rate = rate
        return None

    def tangent(self, sol: Solution, previous: np.ndarray | None, direction: float = 1.0) -> np.ndarray:
        """Unit tangent (scaled) at a solution: orientation kept from ``previous`` or, without
        one, pointing to increasing parameter times ``direction``."""
        m = sol.y.size
        a = np.zeros((m + 1, m + 1))
        a[:m, :m] = sol.jac - np.eye(m)
        a[:m, m] = sol.dpar * self.L / self.Y
        if previous is None:
            a[m, m] = 1.0
        else:
            a[m] = previous
        rhs = np.zeros(m + 1)
        rhs[m] = 1.0
        t = np.linalg.solve(a, rhs)
        t /= np.linalg.norm(t)
        if previous is None:
            if t[m] * direction < 0:
                t = -t
        elif t @ previous < 0:
            t = -t
        return t


def settle(pmap: PeriodMap, y: np.ndarray, p: Forcing, max_periods: int = 400) -> np.ndarray:
    """Integrate the map until it repeats to 1e-6 (or ``max_periods`` forcing periods)."""
    for _ in range(max(1, max_periods // pmap.periods)):
        y1 = pmap.flow(y, p)[0]
        if np.linalg.norm(y1 - y) <= 1e-6 * max(float(np.linalg.norm(y1)), 1e-300):
            return y1
        y = y1
    return y


def orbit_point(
    pmap: PeriodMap,
    param: str,
    sol: Solution,
    forcing: Forcing,
    tangent_param: float,
    labels: Sequence[str] = (),
) -> BranchPoint:
    """The :class:`BranchPoint` of a converged orbit: its Floquet multipliers (eigenvalues of the
    monodromy matrix over the blades and the coil, by decreasing modulus), stability, measures
    and contact structure."""
    p = forcing.with_value(param, sol.lam)
    k = pmap.n_physical  # the blades and the coil at a fixed drive, never the force control
    mult = np.linalg.eigvals(sol.jac[:k, :k])
    mult = mult[np.argsort(-np.abs(mult))]
    return BranchPoint(
        param=param,
        value=float(sol.lam),
        forcing=p,
        periods=pmap.periods,
        state=sol.y / pmap.scale,
        multipliers=mult,
        stable=bool(np.max(np.abs(mult)) < 1.0),
        labels=tuple(labels),
        measures=pmap.measures(sol.data, p, pmap.drive(sol.y, p)),
        tangent_param=float(tangent_param),
        newton_iterations=sol.iterations,
        contact=pmap.contact_structure(sol.data, p),
    )


def solve_orbit(
    pmap: PeriodMap, forcing: Forcing, y0: np.ndarray | None = None, settle_periods: int = 400
) -> BranchPoint:
    """The periodic orbit at fixed ``forcing``: Newton from ``y0`` (default: the response
    without contact, settled by integrating the map), with its multipliers and measures.

    Raises :class:`ContinuationError` if Newton does not converge.
    """
    y = pmap.linear_orbit(forcing) if y0 is None else np.asarray(y0, dtype=float)
    y_scale = max(float(np.linalg.norm(y)), 1e-12)
    solver = Solver(pmap, "fe", forcing, y_scale, 1.0)
    res = solver.fixed(y, forcing.fe)
    if res is None:
        y = settle(pmap, y, forcing, settle_periods)
        solver.Y = max(float(np.linalg.norm(y)), 1e-12)
        res = solver.fixed(y, forcing.fe)
    if res is None:
        raise ContinuationError(
            f"no periodic orbit found at fe = {forcing.fe:g} Hz, force = {forcing.force:g}, "
            f"gap = {forcing.gap * 1e3:g} mm (Newton did not converge from the settled response)"
        )
    sol = solver.finish(res[0], forcing.fe, res[1])
    return orbit_point(pmap, "fe", sol, forcing, 0.0)


@dataclass
class Entry:
    """A converged orbit with its unit tangent (scaled) and its branch point."""

    sol: Solution
    tangent: np.ndarray
    point: BranchPoint
