"""The compiled explicit step against a plain reference of the same scheme.

The reference is the straightforward NumPy form of ``TwoPhase.step`` (twelve packed nodal
fields per point and node, one bincount, einsum transfers; the solver's step before its
optimisation, docs/performance.md). Both start from the same irregular state (points moved
off their placement, random velocities, stresses and pressures) and must agree to 1e-12
relative after a few steps, for every cell type, the three lumpings, both kinematics, the
pressure projection, the blended liquid basis, gravity and the load, FLIP/PIC, explicit and
implicit drag, mass scaling and the three dampers (local, bulk viscosity, fast-part), with
points crossing cell boundaries. Two ranks must give one rank's results (to 1e-10, the
summation order of the nodal sums differs), and the step must never compile.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import check_ok, scene_options, typed
from petsc4py import PETSc

from solver.stepping import kernels, twophase
from solver.model import assembly
from solver.model.grid import Grid
from solver.model.points import place
from solver.model.scene import water_forces
from solver.model.shapes import BLEND


def _params(**opts):
    db = PETSc.Options()
    for key in list(db.getAll()):
        db.delValue(key)
    # The reference has no fast-part damping: off unless a case sets it.
    return scene_options(**{"fast_damping": 0, **opts})


def _dampers(p, grid, S, soil):
    """Bulk viscosity eta (Pa s) and the fast-part damping's rates 2 zeta w1 and w1 (1/s),
    from their definitions (options help): eta = b1 rho_m c1 h, w1 = 2 pi c1 / (4 H), with
    the inertia scaled by S (in layers: the column's mean density and travel-time c1)."""
    c1 = float(soil.wave_speeds(S)["c1"])
    w1 = 2 * np.pi * c1 / (4 * p.size[1])
    return (p.bulk_viscosity * soil.density * S * c1 * min(grid.h),
            2 * p.fast_damping * w1, w1)


def _material(soil, y0):
    """Porosity, grain density (kg/m3), drag coefficient (kg/m3/s) and D (Pa, one per
    point) of the points whose reference heights are y0 (m): in layers, the layer's at y0
    (the points keep the layer they were made in)."""
    layer = soil.layer_of(y0) if len(soil.soils) > 1 else np.zeros(len(y0), dtype=int)
    one = soil.soils
    return (np.array([s.porosity for s in one])[layer], np.array([s.rho_s for s in one])[layer],
            np.array([s.drag_coefficient for s in one])[layer],
            np.stack([s.elasticity() for s in one])[layer])


def _reference_step(grid, p, scheme, bcs, traction, st, dt, load_factor, damping, flip,
                    soil):
    """One step of the plain formulation on the state dict ``st`` (serial) of ``soil``."""
    x, V, vs, vl, sig, pp, J = (st[k] for k in ("x", "V", "vs", "vl", "sig", "pp", "J"))
    visc, vslow = st.get("visc"), st.get("vslow")
    small = scheme.kinematics == "small"
    n, rho_s, drag, D = _material(soil, st["layer_y"])
    gvec = np.array([0.0, -p.gravity])
    ng = grid.gxm * grid.gym
    it = assembly.interpolation(grid, st["x0"] if small else x)
    N, dN, nodes = it.N, it.dNdx, it.nodes
    corner_it = assembly.interpolation(grid, st["x0"] if small else x, corner=True)
    bl = assembly.interpolation(grid, st["x0"] if small else x, blended=True)
    # The solid's transfer: weights w and interpolation Ns, N_hat for both when blended.
    if scheme.lumping == "blended":
        w = Ns = bl.N
    else:
        w, Ns = assembly.lumping_weights(N, scheme.lumping), N
    # The liquid equation's weights and test functions: w and N, or N_hat for both.
    if scheme.liquid_basis == "blended":
        wl, Nl, dNl = bl.N, bl.N, bl.dNdx
    else:
        wl, Nl, dNl = w, N, dN
    # Mass scaling multiplies the inertia; the weight (gravity terms below) stays physical.
    S = scheme.mass_scaling
    ms, ml, mt = (1 - n) * rho_s * V, n * p.rho_l * V, p.rho_l * V
    wm, wt = ms + ml, mt
    ms, ml, mt = S * ms, S * ml, S * mt
    npnt, nen = N.shape
    C = np.empty((npnt, nen, 13))
    C[..., 0] = w * ms[:, None]
    C[..., 1] = wl * ml[:, None]                # the liquid's weights throughout
    C[..., 2] = wl * mt[:, None]
    C[..., 3] = wl * (drag * V)[:, None]
    C[..., 4:6] = (w * ms[:, None])[..., None] * vs[:, None, :]
    C[..., 6:8] = (wl * ml[:, None])[..., None] * vl[:, None, :]
    # The bulk viscosity's stress acts on the mixture like an effective stress.
    ve = visc if visc is not None else 0.0
    sxx, syy, sxy = (sig[:, 0] - pp + ve) * V, (sig[:, 1] - pp + ve) * V, sig[:, 2] * V
    C[..., 8] = -(dN[..., 0] * sxx[:, None] + dN[..., 1] * sxy[:, None])
    C[..., 9] = -(dN[..., 0] * sxy[:, None] + dN[..., 1] * syy[:, None])
    C[..., 10:12] = dNl * (pp * V)[:, None, None]
    corner = scheme.pressure_projection == "corner"
    if corner:
        # The liquid force in gradient form: -N_l V grad p, grad p the points' field.
        C[..., 10:12] = -(Nl * V[:, None])[..., None] * st["gradp"][:, None, :]
    C[..., 8:10] += (N * wm[:, None])[..., None] * gvec
    C[..., 10:12] += (Nl * wt[:, None])[..., None] * gvec
    C[..., 12] = wl * (drag / n * V)[:, None]
    G = np.bincount((nodes[..., None] * 13 + np.arange(13)).ravel(), weights=C.ravel(),
                    minlength=ng * 13).reshape(-1, 13)
    Ms, Ml, Mt, Q = G[:, 0], G[:, 1], G[:, 2], G[:, 3]

    def inv(M):
        return np.divide(1.0, M, out=np.zeros_like(M), where=M > 0)

    vs_n, vl_n = G[:, 4:6] * inv(Ms)[:, None], G[:, 6:8] * inv(Ml)[:, None]
    fm = G[:, 8:10].copy()
    fm[:, 1] += load_factor * traction
    # The water outside drained sides under gravity, at its hydrostatic pressure.
    drained = tuple(s for s in p.drained if s != "none")
    fm += water_forces(grid, drained, p.rho_l * p.gravity).reshape(-1, 2)
    if not corner:      # the corner projection's gradient-form liquid force holds the sides
        G[:, 10:12] += water_forces(grid, drained, p.rho_l * p.gravity,
                                    BLEND if scheme.liquid_basis == "blended" else 1.0
                                    ).reshape(-1, 2)
    if damping:
        fm -= damping * np.abs(fm) * np.sign(Ms[:, None] * vs_n + Ml[:, None] * vl_n)
    fs = grid.constrained_mask(bcs).reshape(-1, 2)
    # Normal to an impermeable side the liquid is tied to the solid (no relative flux): both
    # move by the mixture's equation, and are held where the solid is.
    tie = grid.constrained_mask({s: c for s, c in {"left": "x", "right": "x", "bottom": "y",
                                                   "top": "y"}.items()
                                 if s not in p.drained}).reshape(-1, 2)
    if scheme.drag == "explicit":
        al = (G[:, 10:12] - Q[:, None] * (vl_n - vs_n)) * inv(Mt)[:, None]
        as_ = (fm - Ml[:, None] * al) * inv(Ms)[:, None]
    else:
        as_, al = _implicit_drag(Ms, Ml, Mt, Q, fm, G[:, 10:12], vs_n, vl_n, fs,
                                 np.zeros_like(tie), dt)
    as_ = np.where(tie, fm * inv(Ms + Ml)[:, None], as_)
    as_[fs], vs_n[fs] = 0.0, 0.0
    al, vl_n = np.where(tie, as_, al), np.where(tie, vs_n, vl_n)
    Hn = np.hstack([as_, al, vs_n + dt * as_, vl_n + dt * al])[nodes]
    at = np.einsum("pa,paf->pf", Ns, Hn)
    at[:, 2:4] = np.einsum("pa,paf->pf", Nl, Hn[..., 2:4])
    at[:, 6:8] = np.einsum("pa,paf->pf", Nl, Hn[..., 6:8])
    vs[:] = flip * (vs + dt * at[:, 0:2]) + (1 - flip) * at[:, 4:6]
    vl[:] = flip * (vl + dt * at[:, 2:4]) + (1 - flip) * at[:, 6:8]
    eta, fast, slow = _dampers(p, grid, S, soil)
    if vslow is not None:
        # Both phases lose 2 zeta w1 dt (v_m - v_slow), v_m the momentum-weighted mixture
        # velocity, v_slow its low-pass over 1/w1.
        cs, cl = ((1 - n) * rho_s)[:, None], (n * p.rho_l)[:, None]
        vm = (cs * vs + cl * vl) / (cs + cl)
        vslow += dt * slow * (vm - vslow)
        vs -= dt * fast * (vm - vslow)
        vl -= dt * fast * (vm - vslow)
    Ls = np.einsum("pai,paj->pij", Hn[..., 4:6], dN)
    # Relative motion in the liquid's basis: div v_s + n div(v_l - v_s); in layers n div_w
    # is the divergence of the nodes' Darcy flux n_q (v_l - v_s), n_q = Q / sum w_l V drag / n.
    flux = Hn[..., 6:8] - Hn[..., 4:6]
    if len(soil.soils) > 1:
        flux = flux * (Q * inv(G[:, 12]))[nodes][..., None] / n[:, None, None]
    div_w = np.einsum("pai,pai->p", flux, dNl)
    eps = np.stack([Ls[:, 0, 0], Ls[:, 1, 1], Ls[:, 0, 1] + Ls[:, 1, 0]], axis=1)
    sig += dt * np.einsum("pij,pj->pi", D, eps)
    div_s = Ls[:, 0, 0] + Ls[:, 1, 1]
    dp = dt * p.K_l / n * (div_s + n * div_w)
    x += dt * at[:, 4:6]
    J *= 1 + dt * div_s
    if visc is not None:
        visc[:] = eta * div_s
    if corner:
        # Onto the corners' bilinear field N4: sum V (N4 dt K_l/n div v_s - grad N4 . dt
        # K_l w), w = v_l - v_s in the liquid's basis (the weak divergence), over sum N4 V;
        # held on the drained sides; back to p and grad p.
        w_l = np.einsum("pa,pai->pi", Nl, flux)     # in layers the flux over n
        if grid.element == "q4" and len(soil.soils) == 1 and scheme.liquid_basis != "blended":
            # The compact Darcy stencil: the points' quasi-static flux -(k / gamma_w)
            # (grad p - rho_l g), k / gamma_w = n / drag, less the nodes' (the liquid
            # force over sum w_l V drag / n) interpolated, with dt (K_l / n)(k / gamma_w)
            # capped at h_min^2 / 4.
            kg = n / drag
            qn = G[:, 10:12] * inv(G[:, 12])[:, None]
            dq = -kg[:, None] * (st["gradp"] - p.rho_l * gvec) - np.einsum("pa,pai->pi", Nl,
                                                                            qn[nodes])
            theta = np.minimum(1.0, min(grid.h) ** 2 / 4 / (dt * p.K_l / n * kg))
            w_l = w_l + (theta / n)[:, None] * dq
        # In layers weighted by the storage n / K_l: (n / K_l) dp = -(div v_s + div q) dt.
        Vc = V * (n / p.K_l if len(soil.soils) > 1 else 1.0)
        vals = Vc[:, None] * (corner_it.N * (dt * p.K_l / n * div_s)[:, None]
                              - np.einsum("pai,pi->pa", corner_it.dNdx, dt * p.K_l * w_l))
        num = np.bincount(nodes.ravel(), weights=vals.ravel(), minlength=ng)
        den = np.bincount(nodes.ravel(), weights=(corner_it.N * Vc[:, None]).ravel(),
                          minlength=ng)
        held = grid.constrained_mask({s: "x" for s in p.drained if s != "none"})[::2]
        pn = np.where(held, 0.0, num * inv(den))
        back = corner_it if small else assembly.interpolation(grid, x, corner=True)
        dp = np.einsum("pa,pa->p", back.N, pn[back.nodes])
        st["gradp"] -= np.einsum("pai,pa->pi", back.dNdx, pn[back.nodes])
    elif scheme.pressure_projection == "nodal":
        # Lumped projection onto the nodes, back at the points' new positions.
        num = np.bincount(nodes.ravel(), weights=(w * (V * dp)[:, None]).ravel(), minlength=ng)
        den = np.bincount(nodes.ravel(), weights=(w * V[:, None]).ravel(), minlength=ng)
        back = it if small else assembly.interpolation(grid, x)
        dp = np.einsum("pa,pa->p", back.N, (num * inv(den))[back.nodes])
    pp -= dp


def _implicit_drag(Ms, Ml, Mt, Q, fm, fl, vs, vl, held_s, held_l, dt):
    """Accelerations with backward Euler on the drag, by a 2 x 2 solve per node and
    direction: [[M_s, M_l], [-Q dt, M~_l + Q dt]] (a_s, a_l) = (f_m, f_l - Q (v_l - v_s)),
    a held phase's velocity zero and the other phase's equation alone. A phase without
    positive mass at a node is held there (as 1/M = 0 holds it in the explicit step)."""
    as_, al = np.zeros_like(fm), np.zeros_like(fm)
    held_s = held_s | (Ms <= 0)[:, None]
    held_l = held_l | (Ml <= 0)[:, None]
    for a in range(len(Ms)):
        for d in range(2):
            w = (0.0 if held_l[a, d] else vl[a, d]) - (0.0 if held_s[a, d] else vs[a, d])
            rhs = np.array([fm[a, d], fl[a, d] - Q[a] * w])
            if held_s[a, d] and held_l[a, d]:
                continue
            if held_s[a, d]:
                al[a, d] = rhs[1] / (Mt[a] + Q[a] * dt)
            elif held_l[a, d]:
                as_[a, d] = rhs[0] / Ms[a]
            else:
                A = np.array([[Ms[a], Ml[a]], [-Q[a] * dt, Mt[a] + Q[a] * dt]])
                as_[a, d], al[a, d] = np.linalg.solve(A, rhs)
    return as_, al


CASES = [
    dict(element="q4", cells="4,40"),
    dict(element="q4", cells="4,40", kinematics="large", pressure_projection="none"),
    dict(element="q9", cells="3,30", ppc=3, kinematics="large", pressure_projection="nodal",
         flip=0.5),
    dict(element="q8", cells="3,30", ppc=3, kinematics="large", liquid_basis="element"),
    dict(element="q9", cells="3,30", ppc=3, liquid_basis="blended", gravity=9.81),
    dict(element="q8", cells="20,200", ppc=3, size="0.2,2", kinematics="large",
         pressure_projection="nodal", gravity=9.81),          # many points, all options
    dict(element="q4", cells="4,40", gravity=9.81, flip=0.5, damping=0),
    dict(element="q4", cells="4,40", lumping="hrz", gravity=9.81, ppc=3),
    dict(element="q8", cells="3,30", ppc=3, gravity=9.81),
    dict(element="q9", cells="3,30", ppc=3, drained="top,bottom", flip=0.7),
    dict(element="q4", cells="40,300", size="0.4,3"),           # many points
    dict(element="q9", cells="20,200", ppc=3, size="0.2,2"),
    # The paper's explicit drag, and inertia scaled both ways (with gravity: the weight
    # must stay physical).
    dict(element="q4", cells="4,40", drag="explicit"),
    dict(element="q8", cells="3,30", ppc=3, drag="explicit", gravity=9.81),
    dict(element="q9", cells="3,30", ppc=3, drag="explicit", mass_scaling=0.01),
    dict(element="q4", cells="4,40", gravity=9.81, mass_scaling=1e4, damping=0.3),
    dict(element="q8", cells="3,30", ppc=3, gravity=9.81, mass_scaling=1e-3, k=1e-8),
    dict(element="q4", cells="4,40", drained="top,bottom,left", k=1e-9, mass_scaling=1e6),
    # The dampers beside local damping, alone and together, on every cell type.
    dict(element="q4", cells="4,40", bulk_viscosity=0.3, damping=0),
    dict(element="q4", cells="4,40", fast_damping=0.5, damping=0, gravity=9.81),
    dict(element="q4", cells="4,40", bulk_viscosity=0.2, fast_damping=0.2, flip=0.5,
         kinematics="large", drag="explicit"),
    dict(element="q8", cells="3,30", ppc=3, bulk_viscosity=0.2, fast_damping=0.3,
         gravity=9.81),
    dict(element="q9", cells="3,30", ppc=3, bulk_viscosity=0.2, fast_damping=0.3,
         kinematics="large", pressure_projection="nodal", mass_scaling=100),
    # The lumpings and bases the defaults do not pair: HRZ with the blended basis on Q9,
    # row sums with it on Q8 (its corner row sums are negative), HRZ on Q9 alone.
    dict(element="q9", cells="3,30", ppc=3, lumping="hrz", liquid_basis="blended",
         kinematics="large", flip=0.3),
    dict(element="q8", cells="3,30", ppc=3, lumping="rowsum", liquid_basis="blended",
         drag="explicit", damping=0),
    dict(element="q9", cells="3,30", ppc=3, lumping="blended", liquid_basis="blended",
         pressure_projection="nodal", kinematics="large", flip=0.5),
    dict(element="q9", cells="3,30", ppc=3, lumping="hrz", pressure_projection="nodal"),
    dict(element="q4", cells="4,40", liquid_basis="blended", lumping="hrz", flip=0),
    # Impermeable sides that move (a settling top, a free side): the liquid tied to the
    # solid normal to them, with either drag and basis.
    dict(element="q4", cells="4,40", drained="bottom"),
    dict(element="q8", cells="3,30", ppc=3, drained="bottom", drag="explicit"),
    dict(element="q9", cells="4,4", ppc=3, size="1.2,1.2", drained="left,right"),
    dict(element="q4", cells="8,8", size="1.2,1.2", bc_right="none", liquid_basis="blended",
         lumping="hrz", drag="explicit"),
    # Layered ground: each point its layer's material (masses, drag, weight, D, porosity),
    # with both drags, bases, lumpings and every damper; contrasts of 4 to 10.
    dict(element="q4", cells="4,40", layers="0.3,0.7", E="40e6,10e6", k="2.5e-4,2.5e-5",
         porosity="0.4,0.3", rho_s="2650,2700", nu="0.3,0.2", gravity=9.81),
    dict(element="q4", cells="4,40", layers="0.25,0.25,0.5", E="10e6,40e6,20e6",
         k="1e-3,1e-4,5e-4", drag="explicit", damping=0.3, pressure_projection="nodal"),
    dict(element="q9", cells="3,30", ppc=3, layers="0.4,0.6", E="40e6,10e6", nu="0.25,0.1",
         porosity="0.35,0.45", liquid_basis="blended", kinematics="large", gravity=9.81,
         bulk_viscosity=0.2, fast_damping=0.3, flip=0.5),
    dict(element="q8", cells="3,30", ppc=3, layers="0.5,0.5", k="1e-4,1e-5",
         lumping="hrz", drained="bottom", mass_scaling=10),
    # The corner projection (pressure on the corner nodes' bilinear field), both
    # kinematics, drained through the sides, with the blended basis and layers.
    dict(element="q8", cells="4,4", ppc=3, size="1.2,1.2", drained="left,right",
         pressure_projection="corner"),
    dict(element="q9", cells="4,4", ppc=3, size="1.2,1.2", drained="left,right,top",
         pressure_projection="corner", kinematics="large", drag="explicit", flip=0.5),
    dict(element="q8", cells="3,30", ppc=3, kinematics="large", pressure_projection="corner",
         gravity=9.81, bulk_viscosity=0.2),
    dict(element="q9", cells="3,30", ppc=3, lumping="hrz", liquid_basis="blended",
         pressure_projection="corner", layers="0.4,0.6", E="40e6,10e6", k="1e-4,1e-5"),
    dict(element="q4", cells="4,40", pressure_projection="corner", kinematics="large"),
    # Drained sides under gravity (the water's hydrostatic force) with porosity jumps.
    dict(element="q4", cells="8,8", size="1.2,1.2", drained="top,right,bottom", gravity=9.81,
         layers="0.6,0.6", porosity="0.3,0.5", E="40e6,10e6"),
    dict(element="q8", cells="3,30", ppc=3, liquid_basis="blended", lumping="hrz",
         drained="top,bottom", gravity=9.81, layers="0.5,0.5", porosity="0.3,0.5",
         pressure_projection="corner"),
]


@pytest.mark.parametrize("opts", CASES, ids=lambda o: "-".join(f"{k}{v}" for k, v in o.items()))
def test_step_matches_reference(opts):
    if PETSc.COMM_WORLD.getSize() != 1:
        pytest.skip("serial reference")
    p = _params(**opts)
    grid = Grid(PETSc.COMM_WORLD, p.element, p.cells, p.size)
    t = typed(p)
    layered = len(t.soil.soils) > 1
    points = place(grid, p.ppc, t.soil.density_at if layered else t.soil.density, "uniform",
                   twophase.point_fields(t.scheme, layered))
    scheme = t.scheme
    bcs = t.body.supports
    rng = np.random.default_rng(7)
    with points.fields("x", "x0", "vs", "vl", "stress", "p", "J") as (x, x0, vs, vl, sig, pp,
                                                                       J):
        n = len(J)
        # Moved by up to a third of a cell on Q4 and a fifth on the quadratic cells (many
        # points change cell), kept inside the body; the reference positions x0 a little
        # less. (Further on the quadratic cells, row sums of a few nodes nearly cancel and
        # one ulp of their inverse moves the velocities by 1e-11 relative.)
        amplitude = 0.6 if p.element == "q4" else 0.4
        step = (rng.random((n, 2)) - 0.5) * amplitude * np.array(grid.h)
        x0[:] = np.clip(x + 0.5 * step, 1e-9, np.array(p.size) - 1e-9)
        x += step
        np.clip(x, 1e-9, np.array(p.size) - 1e-9, out=x)
        vs[:] = rng.normal(size=(n, 2)) * 1e-3
        vl[:] = rng.normal(size=(n, 2)) * 1e-3
        sig[:] = rng.normal(size=(n, 3)) * 1e3
        pp[:] = 5e3 + rng.normal(size=n) * 1e3
        J[:] = 1.0
    names = {"x": "x", "x0": "x0", "V": "volume", "vs": "vs", "vl": "vl", "sig": "stress",
             "pp": "p", "J": "J"}
    if p.bulk_viscosity > 0:
        names["visc"] = "visc"
    if p.fast_damping > 0:
        with points.fields("vslow") as vslow:
            vslow[:] = rng.normal(size=vslow.shape) * 1e-4
        names["vslow"] = "vslow"
    if scheme.pressure_projection == "corner":
        with points.fields("gradp") as gradp:
            gradp[:] = rng.normal(size=gradp.shape) * 1e4
        names["gradp"] = "gradp"
    ref = dict(zip(names, points.get(*names.values())))
    ref["layer_y"] = ref["x0"][:, 1].copy()
    if layered:
        with points.fields("layer") as layer:
            layer[:] = t.soil.layer_of(ref["layer_y"])
    model = twophase.TwoPhase(grid, points, t.soil, t.body, t.loading, scheme)
    compiled = kernels.compile_counts()
    dt = 1e-6
    for k in range(3):
        if k == 2:
            # Some points jump into the next cell up between steps (kept node numbers and
            # bincount index must follow).
            with points.fields("x") as x:
                move = np.arange(len(x)) % 5 == 0
                x[move, 1] = np.minimum(x[move, 1] + grid.h[1], p.size[1] - 1e-9)
                ref["x"][:] = x
        ramp = 0.5 + 0.25 * k
        model.step(dt, ramp, p.damping, scheme.flip)
        model.migrate()
        _reference_step(grid, p, scheme, bcs, model.traction, ref, dt, ramp, p.damping,
                        scheme.flip, t.soil)
    # The step compiled nothing: every kernel variant was made (or loaded) at set-up.
    assert kernels.compile_counts() == compiled
    del names["x0"], names["V"]
    got = dict(zip(names, points.get(*names.values())))
    for key, value in got.items():
        scale = np.abs(ref[key]).max()
        err = np.abs(value - ref[key]).max() / scale
        assert err < 1e-12, f"{key}: relative difference {err:.2e}"


RANK_CASES = [
    ("q4", []),
    ("q9", ["-mpm_ppc", "3", "-mpm_kinematics", "large", "-mpm_pressure_projection",
            "nodal", "-mpm_bulk_viscosity", "0.2", "-mpm_fast_damping", "0.3", "-mpm_flip",
            "0.5", "-mpm_gravity", "9.81"]),
    ("q8", ["-mpm_ppc", "3", "-mpm_drag", "explicit"]),
    ("q9", ["-mpm_ppc", "3", "-mpm_pressure_projection", "corner", "-mpm_kinematics",
            "large", "-mpm_drained", "top,left"]),
    ("q8", ["-mpm_ppc", "3", "-mpm_pressure_projection", "corner"]),
]


@pytest.mark.mpi(2)
@pytest.mark.parametrize("element,extra", RANK_CASES,
                         ids=[c[0] + "-corner" * ("corner" in c[1]) for c in RANK_CASES])
def test_two_ranks_equal_one_rank(cli, tmp_path, element, extra):
    """The consolidation scene M2 (2 x 20 cells, cut between the ranks across the column)
    run on 1 and on 2 ranks: every field of every material point in the last checkpoint
    agrees to 1e-10 relative (the ranks sum the nodal fields in another order)."""
    args = ["-mpm_progress", "0", "-mpm_figures", "0", "-mpm_element", element,
            "-mpm_stability_analysis", "0", "-mpm_dt", "1e-5", "-mpm_Tv_end", "0.002",
            "-mpm_Tv_report", "0.002", "-mpm_checkpoint_every", "100", *extra]
    states = []
    for ranks in (1, 2):
        out = tmp_path / f"n{ranks}"
        check_ok(cli(args, ranks=ranks, options_file="consolidation-m2-q4", out_dir=out))
        with np.load(out / "checkpoint.npz") as z:
            layout = json.loads(str(z["layout"]))
            fields, state = z["fields"], json.loads(str(z["state"]))
        columns = dict(zip(layout, np.cumsum([0, *layout.values()])))
        ids = fields[:, columns["id"]]
        states.append((state["step"], fields[np.argsort(ids)], layout, columns))
    (step1, one, layout, columns), (step2, two, _, _) = states
    assert step1 == step2 > 0 and one.shape == two.shape
    for name, width in layout.items():
        a = one[:, columns[name]:columns[name] + width]
        b = two[:, columns[name]:columns[name] + width]
        scale = max(np.abs(a).max(), 1e-300)
        assert np.abs(a - b).max() <= 1e-10 * scale, \
            f"{name}: 2 ranks differ from 1 by {np.abs(a - b).max() / scale:.1e} relative"
