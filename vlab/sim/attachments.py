"""What a planned structure carries besides its member chains: crosspieces, lumped masses, strings,
supports, grounded springs (pendulum plates) and the voice coils' sites.

:class:`AttachmentPlanner` is the part of the planner
(:func:`vlab.sim.planner.plan_structure`) that adds them to the junction
bodies of the member chains, once those exist. :mod:`vlab.sim.builder`
describes how each is modelled.

Sources: Sec. 2.1, 2.2, 2.2.1 of the dissertation (crosspieces, strings,
the grid's pendulum plates ``W Y``); the plant's construction and its checks: docs/plants.md.
"""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from ..units import G_SI
from .hinges import ARM_FREQUENCY_TOL, arm_links, hinge_layout
from .plan import AXIS, Body, Item, Joint, Visual, p3, point_mass, rod


class AttachmentPlanner:
    """The planner's methods that attach crosspieces, masses, strings, supports, springs and coils.

    A mixin of the planner (:mod:`vlab.sim.planner`): it works on the
    planner's bodies, junctions, sites and constraint lists.
    """

    def _crosspiece(self, c) -> None:
        spec = self.spec
        sec = self._section(c.section)
        pj = p3(spec.points[c.point])
        jb = self.bodies[self.junction[c.point]]
        # member direction through the point -> arms perpendicular in the plane
        ev = None
        for m in spec.members:
            if c.point in m.points:
                i = m.points.index(c.point)
                a, b = (m.points[i - 1], m.points[i]) if i > 0 else (m.points[0], m.points[1])
                d = p3(spec.points[b]) - p3(spec.points[a])
                ev = d / np.linalg.norm(d)
                break
        if ev is None:
            raise SimulationError(f"{spec._file()}: crosspiece {c.id!r}: no member passes through point {c.point}")
        perp = np.array([-ev[1], ev[0], 0.0])
        off_default = max([ri.length.si for m in spec.members for ri in m.rigid_inserts if ri.point == c.point] or [0.0])
        offset = spec.mujoco.get("crosspiece_root_offset", off_default)
        if isinstance(offset, bool) or not isinstance(offset, (int, float)) or not 0.0 <= offset < 1.0:
            raise SimulationError(f"{spec._file()}: [mujoco] crosspiece_root_offset = {offset!r}: expected a "
                                  "length in metres, 0 <= offset < 1")
        offset = float(offset)
        L = c.arm_length.si
        n = self.opts.crosspiece_segments or arm_links(L, sec.ei.si, sec.rho_a, c.tip_mass.si, ARM_FREQUENCY_TOL,
                                                           self.opts.hinge_layout)
        self.links[c.id] = n
        frac, comp = hinge_layout(n, self.opts.hinge_layout)
        k_bend = [sec.ei.si / (cf * L) for cf in comp]
        jb.items.append(point_mass(pj, c.clamp_mass.si))
        for sign, label in ((1.0, "a"), (-1.0, "b")):
            d = sign * perp
            axis = np.array([d[1], -d[0], 0.0])
            root = pj + offset * d
            hinges = [root + f * L * d for f in frac]
            jb.items.append(rod(root, hinges[0], sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
            self._bar_visual(jb, pj, hinges[0], sec, (0.75, 0.75, 0.8, 1.0))
            parent = jb.name
            for k in range(n):
                h = hinges[k]
                joint = Joint(f"{c.id}.arm{label}.h{k + 1}.bend", "hinge", axis, h, k_bend[k], True,
                               f"spec: crosspiece {c.id} arm {label} hinge {k + 1}/{n}: bending EI/(c L) = {k_bend[k]:.6g} N*m/rad")
                end = hinges[k + 1] if k < n - 1 else root + L * d
                b = self._add(Body(f"{c.id}.arm{label}.link{k + 1}", h, parent,
                                    f"spec: crosspiece {c.id} arm {label} link {k + 1}/{n}", [joint]))
                b.items.append(rod(h, end, sec.rho_a, sec.rho_ip, sec.width.si, sec.thickness.si))
                self._bar_visual(b, h, end, sec, (0.75, 0.75, 0.8, 1.0))
                if k == n - 1:
                    b.items.append(point_mass(end, c.tip_mass.si))
                    b.visuals.append(Visual("sphere", end, (0.012,), rgba=(0.8, 0.3, 0.2, 1.0)))
                    b.sites.append((f"{c.id}.tip{label}", end, f"spec: crosspiece {c.id} tip {label}"))
                parent = b.name

    def _masses(self) -> None:
        for lm in self.spec.masses:
            b = self.bodies[self.junction[lm.point]]
            if lm.id in set(self._plates().values()):
                continue  # realised as a pendulum plate in _springs
            p = p3(self.spec.points[lm.point])
            b.items.append(point_mass(p, lm.mass.si, lm.inertia_rx.si if lm.inertia_rx else 0.0,
                                       lm.inertia_ry.si if lm.inertia_ry else 0.0))
            b.visuals.append(Visual("sphere", p, (0.008,), rgba=(0.2, 0.3, 0.8, 1.0)))

    def _strings(self) -> None:
        for s in self.spec.strings:
            tension = float(self.gs.string_tensions[s.id])
            L = s.length.si
            p = p3(self.spec.points[s.point])
            anchor = p + L * np.array([s.direction[0], s.direction[1], 0.0])
            b = self.bodies[self.junction[s.point]]
            ws, bs = f"{s.id}.anchor", f"{s.id}.end"
            self.world_sites.append((ws, anchor, f"spec: string {s.id} ground anchor"))
            b.sites.append((bs, p, f"spec: string {s.id} attachment"))
            b.items.append(point_mass(p, s.rho_a.si * L / 3.0))  # as the FE string element
            self.strings.append((f"string.{s.id}", ws, bs, tension / L, tension,
                                 f"spec: string {s.id}: T = {tension:.6g} N, L = {L:.6g} m, T/L = {tension / L:.6g} N/m"))

    def _supports(self) -> None:
        for s in self.spec.supports:
            if s.point in self.roots:
                continue  # its fixed DOFs are left out of the junction's joints (_root_joints)
            fixed = set(s.fixed)
            rot_active = {d for d in ("rx", "ry") if d in self.active}
            b = self.bodies[self.junction[s.point]]
            p = p3(self.spec.points[s.point])
            if self.forest:  # a junction inside a chain: its fixed DOFs held to the ground, to first order
                dofs = tuple(d for d in ("w", "rx", "ry") if d in fixed and (d == "w" or d in rot_active))
                if dofs:
                    s1, s2 = f"support{s.point}", f"support{s.point}.ground"
                    b.sites.append((s1, p, f"spec: support at point {s.point}"))
                    self.world_sites.append((s2, p, f"spec: support at point {s.point} (ground)"))
                    self.closures.append((f"support{s.point}", s1, s2, dofs,
                                          f"spec: support at point {s.point} fixes {sorted(fixed)}"))
                continue
            if fixed == {"w"}:
                kind = "connect"
            elif fixed == {"w"} | rot_active:
                kind = "weld"
            elif not fixed:
                continue
            else:
                raise SimulationError(
                    f"{self.spec._file()}: support at point {s.point} fixes {sorted(fixed)}: the MuJoCo plant "
                    "can fix w alone (connect) or w with all active rotations (weld) at a non-root point"
                )
            s1, s2 = f"support{s.point}", f"support{s.point}.ground"
            cut = self._inplane_release(f"J{s.point}.release", b.name, p,
                                        f"support at point {s.point}: in-plane release of its {kind}")
            cut.sites.append((s1, p, f"spec: support at point {s.point}"))
            self.world_sites.append((s2, p, f"spec: support at point {s.point} (ground)"))
            (self.connects if kind == "connect" else self.welds).append(
                (f"support{s.point}", s1, s2, f"spec: support at point {s.point} fixes {sorted(fixed)}"))

    def _plates(self) -> dict[str, str]:
        """Spring id -> mass id of the pendulum plates.

        ``[mujoco] pendulum_plates`` may give the table explicitly, or ``false`` to
        disable plates. By default a grounded rotational spring about an axis
        perpendicular to gravity becomes a pendulum plate when exactly one lumped
        mass at its point has a rotary inertia about that axis of at least
        ``m Y^2`` with ``Y = k / (m g)`` (the plate's own inertia cannot be
        negative), as for the grid's plates (Sec. 2.2.1: ``W Y`` springs).
        """
        if hasattr(self, "_plates_cache"):
            return self._plates_cache
        spec = self.spec
        plates = spec.mujoco.get("pendulum_plates", None)
        if plates is False:
            plates = {}
        elif plates is None:
            plates = {}
            g = np.array([*spec.gravity_direction, 0.0])
            for sp in spec.springs:
                if sp.dof not in ("rx", "ry") or abs(np.dot(AXIS[sp.dof], g)) > 1e-9:
                    continue
                cands = []
                for lm in spec.masses:
                    if lm.point != sp.point:
                        continue
                    irot = lm.inertia_rx if sp.dof == "rx" else lm.inertia_ry
                    ecc = sp.stiffness.si / (lm.mass.si * G_SI)
                    if irot is not None and irot.si >= lm.mass.si * ecc**2 * (1 - 1e-9):
                        cands.append(lm.id)
                if len(cands) == 1:
                    plates[sp.id] = cands[0]
        elif not isinstance(plates, dict):
            raise SimulationError(f"{spec._file()}: [mujoco] pendulum_plates must be a table "
                                  "{ <spring id> = \"<mass id>\" } or false")
        self._plates_cache = dict(plates)
        return self._plates_cache

    def _springs(self) -> None:
        spec = self.spec
        plates = self._plates()
        masses = {m.id: m for m in spec.masses}
        for sp in spec.springs:
            p = p3(spec.points[sp.point])
            b = self.bodies[self.junction[sp.point]]
            if sp.id in plates:
                mid = plates[sp.id]
                if mid not in masses or masses[mid].point != sp.point:
                    raise SimulationError(f"{spec._file()}: [mujoco] pendulum_plates.{sp.id} = {mid!r}: "
                                          f"no mass of that id at point {sp.point}")
                if sp.dof not in ("rx", "ry"):
                    raise SimulationError(f"{spec._file()}: pendulum plate for spring {sp.id!r} on DOF {sp.dof!r}: "
                                          "only a rotation can be a pendulum")
                lm = masses[mid]
                g = np.array([*spec.gravity_direction, 0.0])
                axis = AXIS[sp.dof]
                if abs(np.dot(axis, g)) > 1e-9:
                    raise SimulationError(f"{spec._file()}: spring {sp.id!r}: a pendulum about {sp.dof} needs "
                                          "gravity perpendicular to that axis")
                ecc = sp.stiffness.si / (lm.mass.si * G_SI)  # W * Y = k  ->  Y = k / W
                irot = lm.inertia_rx if sp.dof == "rx" else lm.inertia_ry
                i_axis = irot.si if irot is not None else lm.mass.si * ecc**2
                i_own = i_axis - lm.mass.si * ecc**2
                if i_own < -1e-12 * max(i_axis, 1e-30):
                    raise SimulationError(
                        f"{spec._file()}: pendulum plate {mid!r}: its inertia about the axis ({i_axis:.4g} kg*m^2) "
                        f"is less than m*Y^2 = {lm.mass.si * ecc**2:.4g} with Y = k/W = {ecc:.4g} m"
                    )
                c = p + ecc * g
                iother = lm.inertia_ry if sp.dof == "rx" else lm.inertia_rx
                own = max(i_own, 0.0)
                other = iother.si if iother is not None else 0.0
                diag = [own, other, own] if sp.dof == "rx" else [other, own, own]
                b.items.append(Item(lm.mass.si, c, np.diag(diag)))
                b.visuals.append(Visual("box", c, (0.05, 0.05, 0.009), rgba=(0.7, 0.7, 0.3, 1.0)))
                b.sites.append((f"{sp.id}.plate", c, f"spec: spring {sp.id} as pendulum plate {mid}: "
                                f"W = {lm.mass.si * G_SI:.5g} N at Y = {ecc:.5g} m"))
                continue
            if sp.point in self.roots:
                name = f"root{sp.point}.{sp.dof}"
                for j in b.joints:
                    if j.name == name:
                        j.stiffness += sp.stiffness.si
                        j.info += f"; spring {sp.id} {sp.stiffness.si:.6g}"
                        break
                else:
                    raise SimulationError(f"{spec._file()}: spring {sp.id!r} acts on DOF {sp.dof!r} of point "
                                          f"{sp.point}, which is fixed or inactive")
                continue
            self.pending_springs.append(sp)

    def _instrumentation(self) -> None:
        ins = self.spec.instrumentation
        if ins is None:
            return
        for p in ins.actuators:
            b = self.bodies[self.junction[p]]
            pos = p3(self.spec.points[p])
            b.sites.append((f"coil{p}", pos, f"spec: voice-coil actuator at point {p}"))
            self.world_sites.append((f"coil{p}_ref", pos, f"spec: voice-coil magnet (ground) at point {p}"))
