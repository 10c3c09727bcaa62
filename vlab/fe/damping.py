"""The structure's damping matrix, and what it gives the modes of a changed structure.

vlab's structures are damped by their measured open-loop modal damping ratios (Sec. 2.1.2: "proportional
damping equivalent to the measured open loop inherent damping"): the damping matrix

    C = M Phi diag(2 zeta_r omega_r) Phi^T M        (Phi mass-normalised, Phi^T M Phi = I)

gives each mode exactly its ratio (Caughey & O'Kelly, J. Appl. Mech. 32 (1965) 583-588: classical damping).

A physical change added to a structure -- a mass, a grounded spring, a stiffer or softer member or joint --
does not change what dissipates energy in it: the changed structure keeps the *unchanged* structure's
damping matrix ``C0`` (its spec names that structure as :attr:`vlab.spec.Damping.basis`). Its modes then
carry the ratios ``C0`` gives them, to first order in the damping

    zeta_r' = phi_r'^T C0 phi_r' / (2 omega_r')                                        (diagonal projection)

so an added mass lowers a mode's ratio with its frequency and an added stiffness raises the frequency and
lowers the ratio: for a change that keeps the mode's shape, ``zeta' = zeta omega'/omega`` for a mass and
``zeta' = zeta omega/omega'`` for a stiffness. vlab's MuJoCo plant behaves so (its applied modal damping is
a fixed matrix stored with the model), and so do dissipation mechanisms of joints and materials more
closely than a fixed ratio would (Adhikari, *Damping Models for Structural Vibration*, PhD thesis,
Cambridge, 2000, ch. 2). The off-diagonal terms ``phi_r'^T C0 phi_s'`` (non-classical damping) are left
out; for the lightly damped structures here they shift no ratio by more than its square.

``C0`` is carried DOF by DOF (by the DOF labels; an interior node of a split member, renamed by the split,
by its place): a DOF the changed structure has and the unchanged one does not (a support released to attach
a spring) has no damping from it.
"""

from __future__ import annotations

import numpy as np

from .assembly import FEModel, build_fe_model
from .modal import Modes, modal_analysis

#: Unchanged structures' FE models and modes, by the identity of their spec (a diagnosis edits one spec many
#: times): (spec, FE model, modes).
_BASIS_CACHE: dict[int, tuple] = {}
_CACHE_SIZE = 8
#: Damping matrices of changed structures carried from their unchanged structure, by (identity of the
#: unchanged spec, the ratios, the changed model's DOF labels): (spec, matrix). The matrices are read-only.
_MATRIX_CACHE: dict[tuple, tuple] = {}


def open_loop_ratios(spec, n: int) -> np.ndarray:
    """The spec's modal damping ratios extended with its default to ``n`` modes, shape (n,) [1]."""
    z = list(spec.damping.modal_ratios) if spec.damping else []
    default = spec.damping.default_ratio if spec.damping else 0.0
    return np.array((z + [default] * n)[:n])


def modal_damping_matrix(m: np.ndarray, k: np.ndarray, ratios: np.ndarray, modes: Modes | None = None) -> np.ndarray:
    """Damping matrix with prescribed modal damping ratios (classical damping).

    ``c = m Phi diag(2 zeta_i omega_i) Phi^T m`` with mass-normalised ``Phi``, so
    that ``Phi^T c Phi = diag(2 zeta_i omega_i)`` (Sec. 2.1.2: "proportional
    damping equivalent to the measured open loop damping").

    Parameters
    ----------
    m, k : ndarray, shape (n, n)
        Mass [kg] and stiffness [N/m] matrices.
    ratios : ndarray, shape (n,)
        Damping ratio of every mode, in frequency order.
    modes : Modes, optional
        ``modal_analysis(m, k)``, when already computed.

    Returns
    -------
    ndarray, shape (n, n) [N*s/m]

    Raises
    ------
    ModelError
        As :func:`vlab.fe.modal_analysis`.
    """
    modes = modal_analysis(m, k) if modes is None else modes
    a = m @ modes.shapes
    return (a * (2.0 * np.asarray(ratios) * modes.omega)) @ a.T


def _basis(spec) -> tuple[FEModel, Modes]:
    key = id(spec)
    hit = _BASIS_CACHE.get(key)
    if hit is not None and hit[0] is spec:
        return hit[1], hit[2]
    fe = build_fe_model(spec)
    md = modal_analysis(fe.m, fe.k)
    if len(_BASIS_CACHE) >= _CACHE_SIZE:
        _BASIS_CACHE.pop(next(iter(_BASIS_CACHE)))
    _BASIS_CACHE[key] = (spec, fe, md)
    return fe, md


def _carried(base: FEModel, fe: FEModel) -> list[tuple[int, int | None]]:
    """``(i, j)``: the DOF ``j`` of the unchanged structure ``base`` that DOF ``i`` of ``fe`` is, or None.

    A DOF is the same DOF when its label is (a point's DOF), else when its node lies at the same place with the
    same DOF name and no other node of ``base`` does: a changed member is split into pieces with their own ids
    (:func:`vlab.diagnose.effects.specedit.scale_segments`), which renames the interior nodes of a mesh with
    more than one element per segment (``"<member>.<segment>.<k>"``) but does not move them.
    """
    claimed = {base.dofs._index[lab] for lab in fe.dofs.labels if lab in base.dofs}
    at: dict[tuple, int | None] = {}
    for j, (node, dof) in enumerate(base.dofs.labels):
        xy = base.mesh.nodes.get(node)
        if isinstance(node, str) and xy is not None and j not in claimed:
            key = (round(xy[0], 9), round(xy[1], 9), dof)
            at[key] = None if key in at else j  # two interior nodes at one place: not carried by place
    out, used = [], set()
    for i, lab in enumerate(fe.dofs.labels):
        j = base.dofs._index.get(lab)
        if j is None and isinstance(lab[0], str):
            xy = fe.mesh.nodes.get(lab[0])
            j = None if xy is None else at.get((round(xy[0], 9), round(xy[1], 9), lab[1]))
            j = None if j in used else j  # one base DOF is carried to one DOF at most
            used.add(j)
        out.append((i, j))
    return out


def structural_damping(fe: FEModel, spec=None) -> np.ndarray:
    """The damping matrix of the structure of ``fe`` [N*s/m], shape (n, n).

    The spec's modal ratios on the modes of ``fe`` (:func:`modal_damping_matrix`), or, when the spec names an
    unchanged structure (:attr:`vlab.spec.Damping.basis`), that structure's matrix with the spec's ratios,
    carried DOF by DOF (by label, an interior node by place: :func:`_carried`; zero for DOFs the unchanged
    structure lacks). ``spec``: the spec whose damping
    applies (default ``fe.spec``; a lab whose damping was edited without rebuilding its FE model passes its
    own).

    The matrix carried from an unchanged structure is cached and read-only (copy it to add to it).

    Raises
    ------
    ModelError
        As :func:`vlab.fe.modal_analysis`, for ``fe`` or the unchanged structure.
    """
    spec = fe.spec if spec is None else spec
    d = spec.damping
    if d is None or d.basis is None:
        return modal_damping_matrix(fe.m, fe.k, open_loop_ratios(spec, fe.n))
    base, md = _basis(d.basis)
    ratios = open_loop_ratios(spec, base.n)
    key = (id(d.basis), ratios.tobytes(), tuple(fe.dofs.labels))
    hit = _MATRIX_CACHE.get(key)
    if hit is not None and hit[0] is d.basis:
        return hit[1]
    c0 = modal_damping_matrix(base.m, base.k, ratios, md)
    if base.dofs.labels == fe.dofs.labels:
        c = c0
    else:
        rows = _carried(base, fe)
        keep = [(i, j) for i, j in rows if j is not None]
        ii = np.array([i for i, _ in keep], dtype=int)
        jj = np.array([j for _, j in keep], dtype=int)
        c = np.zeros((fe.n, fe.n))
        c[np.ix_(ii, ii)] = c0[np.ix_(jj, jj)]
    c.setflags(write=False)
    if len(_MATRIX_CACHE) >= _CACHE_SIZE:
        _MATRIX_CACHE.pop(next(iter(_MATRIX_CACHE)))
    _MATRIX_CACHE[key] = (d.basis, c)
    return c


def structural_ratios(fe: FEModel, modes: Modes, spec=None) -> np.ndarray:
    """Modal damping ratios [1] of the modes ``modes`` of ``fe``, shape (n_modes,).

    The spec's own ratios (:func:`open_loop_ratios`) when it names no unchanged structure; else the
    diagonal projection ``phi_r^T C0 phi_r / (2 omega_r)`` of the unchanged structure's damping matrix
    (:func:`structural_damping`). ``spec`` as there.

    Raises
    ------
    ModelError
        As :func:`structural_damping`.
    """
    spec = fe.spec if spec is None else spec
    d = spec.damping
    if d is None or d.basis is None:
        return open_loop_ratios(spec, modes.shapes.shape[1])
    c = structural_damping(fe, spec)
    phi = modes.shapes
    return np.sum(phi * (c @ phi), axis=0) / (2.0 * modes.omega)
