"""The in-plane redundant forces of the FE gravity statics, applied to a planned plant as constant loads.

The kinematic tree (or forest) of the plant has no in-plane DOFs, so MuJoCo
cannot share the in-plane loads of a statically indeterminate structure;
the FE statics' redundant forces (:func:`vlab.fe.statics.solve_gravity`:
the internal force and moment at each loop cut, the reaction at each further
in-plane support) are applied as ``prestress*`` loads instead (see
:mod:`vlab.sim.planner`, "Topology"). :class:`PrestressPlanner` is that part
of the planner.

Sources: Sec. 2.2 of the dissertation; the plant's construction: docs/plants.md.
"""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from ..units import G_SI
from .plan import p3


def held_inplane(support) -> bool:
    """True for a support pinned or clamped in the plane.

    Parameters
    ----------
    support : vlab.spec.Support
        Its ``inplane`` is ``"pinned"``, ``"clamped"`` or true for a held one.

    Returns
    -------
    bool
    """
    return support.inplane in ("pinned", "clamped", True)


class PrestressPlanner:
    """The planner's methods that turn the FE statics' redundant forces into constant loads.

    A mixin of the planner (:mod:`vlab.sim.planner`): it reads the planner's
    spec, gravity state, mesh, loop cuts and bodies, and adds sites and
    ``prestress`` loads.
    """

    def _redundants(self) -> None:
        """Constant in-plane loads that reproduce the FE statics' redundant forces."""
        spec, gs, mesh = self.spec, self.gs, self.mesh
        el_index = {}
        for i, el in enumerate(mesh.elements):
            el_index.setdefault((el.member, el.a), []).append(i)
            el_index.setdefault((el.member, el.b), []).append(i)

        def end_force(member, seg, a, b, at):
            """Force [N] and moment [N m] (world) that node ``at`` exerts on the member segment a-b."""
            for i in el_index.get((member.id, at), []):
                el = mesh.elements[i]
                other = el.b if el.a == at else el.a
                inner = isinstance(other, str) and other.startswith(f"{member.id}.{seg}.")
                if not (inner or other in (a, b)):
                    continue
                f = gs.element_forces[i]
                ex, ey = el.direction
                if el.a == at:
                    fx, fy, mz = -f.axial[0], f.shear[0], -f.moment[0]
                else:
                    fx, fy, mz = f.axial[1], -f.shear[1], f.moment[1]
                force = fx * np.array([ex, ey, 0.0]) + fy * np.array([-ey, ex, 0.0])
                return force, mz
            raise SimulationError(f"internal: no FE element of member {member.id} at point {at}")

        scale = max(1.0, sum(it.mass for b in self.bodies.values() for it in b.items) * G_SI)
        for e, q, stub in self.cuts:
            force, mz = end_force(e.member, e.seg, e.a, e.b, q)
            pos = p3(spec.points[q])
            tag = f"{e.member.id}.{min(e.a, e.b)}-{max(e.a, e.b)}"
            self._dead_load(f"prestress.{tag}.{q}", stub, pos, force, mz, scale,
                            f"FE statics: in-plane force and moment of point {q} on member {e.member.id} "
                            f"at its loop cut (reaction on J{q})", ref_body=self.junction[q])
        # a junction hung from the world (the tree's root, the forest's hung junctions) is held in the plane
        # there: the reaction of its support needs no load
        for s in spec.supports:
            if held_inplane(s) and s.point not in self.roots:
                r, mr = self._reaction(s.point, end_force)
                if s.inplane != "clamped":
                    mr = 0.0
                self._dead_load(f"prestress.support{s.point}", self.junction[s.point], p3(spec.points[s.point]),
                                r, mr, scale, f"FE statics: in-plane reaction of the support at point {s.point}")

    def _reaction(self, point: int, end_force) -> np.ndarray:
        spec = self.spec
        total = np.zeros(3)
        moment = 0.0
        for m in spec.members:
            for i, (a, b) in enumerate(zip(m.points[:-1], m.points[1:])):
                if point in (a, b):
                    f, mz = end_force(m, i, a, b, point)
                    total += f
                    moment += mz
        g = G_SI * np.array([*spec.gravity_direction, 0.0])
        ext = np.zeros(3)
        for lm in spec.masses:
            if lm.point == point:
                ext += lm.mass.si * g
        for c in spec.crosspieces:
            if c.point == point:
                arm = spec.sections[c.section].rho_a * c.arm_length.si
                ext += (2 * (arm + c.tip_mass.si) + c.clamp_mass.si) * g
        for s in spec.strings:
            if s.point == point and s.tension is not None:
                ext += s.tension.si * np.array([*s.direction, 0.0])
        return total - ext, moment

    def _dead_load(self, name, body, pos, force, moment, scale, info, ref_body: str | None = None) -> None:
        """A constant force [N] and moment about z [N m] on ``body`` at ``pos``.

        With ``ref_body`` the load is a pair: the equal and opposite load acts on
        ``ref_body`` (the actuator's refsite is on it), else the reaction goes to
        the world (a world-fixed refsite: a dead load).
        """
        tol = 1e-9 * scale
        wrench = np.array([force[0], force[1], 0.0, 0.0, 0.0, moment])
        if np.linalg.norm(wrench) <= tol:
            return
        b = self.bodies[body]
        site, ref = name, f"{name}_ref"
        b.sites.append((site, pos, info))
        if ref_body is None:
            self.world_sites.append((ref, pos, info + " (ground frame)"))
        else:
            self.pending_sites.append((int(ref_body[1:]), ref, pos, info + " (reaction side)"))
        self.prestress.append((name, site, ref, wrench,
                               info + f": F = ({force[0]:.6g}, {force[1]:.6g}) N, M = {moment:.6g} N*m"))
