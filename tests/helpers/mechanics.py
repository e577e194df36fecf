"""Plain-numpy mechanics of a :class:`helpers.models.Spec` along a trajectory: the
Newton-Euler balance of every body, the kinetic and potential energy (model units,
global axes).  It reads only the motion (postures, screws, points of the trajectory)
and the data the Spec recorded."""

from __future__ import annotations

import numpy as np

import openimp
from helpers.models import Spec


class Ref:
    """Plain-numpy mechanics of a Spec along a trajectory (model units, global axes)."""

    def __init__(self, spec: Spec, tr: openimp.Trajectory) -> None:
        self.spec = spec
        self.tr = tr
        self.rates = tr.has_rates

    # --------------------------------------------------------------- bodies
    def moved(self, body):
        """T_0b(step) T_0b(modeling)^-1 (n, 4, 4): what carries the body's points from
        the modeling posture, where they were given, to every step."""
        return self.tr.posture(body) @ np.linalg.inv(self.spec.model.body_frames[body])

    def centre(self, body):
        """Centre of mass (n, 3), its velocity and acceleration (zeros without rates)."""
        _, c0, _ = self.spec.mass[body]
        T = self.moved(body)
        c = np.einsum("nij,j->ni", T[:, :3, :3], c0) + T[:, :3, 3]
        if not self.rates:
            return c, np.zeros_like(c), np.zeros_like(c)
        V, A = self.tr.velocity_screw(body), self.tr.acceleration_screw(body)
        v, w, a, al = V[:, :3], V[:, 3:], A[:, :3], A[:, 3:]
        vc = v + np.cross(w, c)
        ac = a + np.cross(al, c) + np.cross(w, vc)
        return c, vc, ac

    def inertia(self, body):
        """Centroidal inertia on global axes (n, 3, 3)."""
        _, _, I0 = self.spec.mass[body]
        R = self.moved(body)[:, :3, :3]
        return R @ I0 @ np.swapaxes(R, 1, 2)

    def kinetic(self):
        """T = sum 1/2 m |v_c|^2 + 1/2 w . I_c w (n,)."""
        T = np.zeros(self.tr.nsteps)
        for b, (m, _, _) in self.spec.mass.items():
            _, vc, _ = self.centre(b)
            w = self.tr.velocity_screw(b)[:, 3:]
            T += 0.5 * m * np.sum(vc * vc, 1) + 0.5 * np.einsum("ni,nij,nj->n", w,
                                                                self.inertia(b), w)
        return T

    # --------------------------------------------------------------- elements
    def length(self, p1, p2):
        """Length (n,), its rate (n,) and the unit vector from p2 to p1 (n, 3)."""
        d = self.tr.point(p1) - self.tr.point(p2)
        ln = np.linalg.norm(d, axis=1)
        u = d / ln[:, None]
        if not self.rates:
            return ln, np.zeros_like(ln), u
        dv = self.tr.point_velocity(p1) - self.tr.point_velocity(p2)
        return ln, np.sum(u * dv, 1), u

    def direction(self, direction):
        """A fixed global direction or the unit vector from point a toward point b (n, 3)."""
        if isinstance(direction[0], str):
            d = self.tr.point(direction[1]) - self.tr.point(direction[0])
        else:
            d = np.tile(np.asarray(direction, float), (self.tr.nsteps, 1))
        return d / np.linalg.norm(d, axis=1)[:, None]

    def potential(self):
        """V = -sum m g.c + 1/2 k (l - l0)^2 of the point springs + 1/2 k (q - q0)^2 of the
        joint springs (n,)."""
        V = np.zeros(self.tr.nsteps)
        for b, (m, _, _) in self.spec.mass.items():
            V -= m * self.centre(b)[0] @ self.spec.gravity
        for _, p1, p2, k, l0 in self.spec.springs:
            V += 0.5 * k * (self.length(p1, p2)[0] - l0) ** 2
        for j, (k, q0) in self.spec.jsprings.items():
            V += 0.5 * k * (self.tr.variable(j) - q0) ** 2
        return V

    def applied(self, body):
        """Applied loads on ``body`` (gravity, point springs and dampers, forces and
        torques): a list of (force (n, 3), point of application (n, 3) or None for a
        pure moment (then ``force`` is the moment))."""
        out = []
        n = self.tr.nsteps
        if body in self.spec.mass:
            m = self.spec.mass[body][0]
            out.append((np.tile(m * self.spec.gravity, (n, 1)), self.centre(body)[0]))
        pairs = [(p1, p2, k * (self.length(p1, p2)[0] - l0))
                 for _, p1, p2, k, l0 in self.spec.springs]
        pairs += [(p1, p2, c * self.length(p1, p2)[1]) for _, p1, p2, c in self.spec.dampers]
        for p1, p2, t in pairs:  # tension t pulls the two ends together
            u = self.length(p1, p2)[2]
            if self.spec.points[p1] == body:
                out.append((-t[:, None] * u, self.tr.point(p1)))
            if self.spec.points[p2] == body:
                out.append((t[:, None] * u, self.tr.point(p2)))
        for _, p, f, d in self.spec.forces:
            if self.spec.points[p] == body:
                out.append((f * self.direction(d), self.tr.point(p)))
        for _, b, t, d in self.spec.torques:
            if b == body:
                out.append((t * self.direction(d), None))
        return out

    def joint_origin(self, joint):
        """Origin of the joint frame on its first body (n, 3)."""
        J = self.spec.model.joints[joint]
        return np.einsum("nij,j->ni", self.moved(J.body1), J.frame1[:, 3])[:, :3]

    def balance(self, F: openimp.Forces, body):
        """Newton-Euler residuals of ``body``: (n, 3) force and (n, 3) moment about the
        centre (sum of the loads minus m a_c, minus I_c alpha + w x I_c w), and their
        scales (the largest force and the largest moment term met)."""
        m, _, _ = self.spec.mass[body]
        c, _, ac = self.centre(body)
        n = self.tr.nsteps
        fres = -m * ac
        mres = np.zeros((n, 3))
        if self.rates:
            w = self.tr.velocity_screw(body)[:, 3:]
            al = self.tr.acceleration_screw(body)[:, 3:]
            Ic = self.inertia(body)
            mres = -(np.einsum("nij,nj->ni", Ic, al) + np.cross(w, np.einsum("nij,nj->ni",
                                                                              Ic, w)))
        sf, sm = float(np.max(np.abs(fres))), float(np.max(np.abs(mres)))
        loads = self.applied(body)
        for j, J in self.spec.model.joints.items():
            if body not in (J.body1, J.body2):
                continue
            R = F.reaction(j, "global")
            sgn = 1.0 if body == J.body2 else -1.0  # first body on second: +, its reaction -
            loads.append((sgn * R[:, :3], self.joint_origin(j)))
            loads.append((sgn * R[:, 3:], None))
        for f, r in loads:
            mom = f if r is None else np.cross(r - c, f)
            if r is not None:
                fres = fres + f
                sf = max(sf, float(np.nanmax(np.abs(f))))
            mres = mres + mom
            sm = max(sm, float(np.nanmax(np.abs(mom))))
        return fres, mres, sf, sm
