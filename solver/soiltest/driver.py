"""One material point through a laboratory test (:mod:`solver.materials.soiltest`).

Writes ``soiltest.csv`` (per step: axial and volumetric strain, p', q, the excess pore
pressure and the stresses, Pa, compression positive), a figure of the stress path and of q
against the axial strain (the cyclic test: the shear stress-strain loops), and the
summary's ``soiltest`` block: ``peak_q_pa``, ``final_p_eff_pa``, ``final_q_pa`` (plane
strain: q = sigma_1 - sigma_3); the cyclic test adds its last cycle's ``g_over_gmax`` and
``damping_ratio``, and for the hyperbolic soil the hyperbola's and Masing's closed forms
beside them (:mod:`solver.references.analytic`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..io import output, provenance
from ..io.output import Outputs
from ..materials import catalog, soiltest
from ..references import analytic
from ..run.record import Record, guarded, owned

COLUMNS = ("axial_strain", "volumetric_strain", "p_eff_pa", "q_pa", "excess_pore_pressure_pa")
STRESSES = ("sigma_xx_pa", "sigma_yy_pa", "sigma_zz_pa", "sigma_xy_pa")


@dataclass(frozen=True)
class SoilTestPlan:
    """What the options ask: the test, its material (built and checked), the start
    (Pa), the strain at the end and the steps, where the results go, the provenance."""

    test: str
    name: str
    material: object
    confining: float
    strain_end: float
    steps: int
    cycles: int
    outputs: Outputs
    provenance: dict

    @classmethod
    def from_options(cls, p) -> "SoilTestPlan":
        material = catalog.Recipe.from_options(p).make(p.E, p.nu)
        return cls(p.soiltest, p.material, material, p.confining, p.strain_end,
                   p.strain_steps, p.cycles, Outputs(p.output, p.summary or
                                           os.path.join(p.output, "summary.json"),
                                           p.figures, p.figure_format),
                   provenance.options(p))


def run(p, comm) -> int:
    """The soil test of the options ``p`` (one point: every rank computes it, rank 0
    writes); returns 0."""
    plan = SoilTestPlan.from_options(p)
    record = Record("soiltest", comm)
    signals.stage("set-up: the soil test")
    with owned(comm):
        guarded(record, lambda: _analysis(plan, comm, record))
    return 0


def _analysis(plan, comm, record) -> None:
    outputs = plan.outputs
    record.begin(outputs, None, plan.provenance)
    record.enter("stepping")
    path = soiltest.run(plan.material, plan.test, plan.confining, plan.strain_end, plan.steps,
                        plan.cycles)
    record.steps = len(path["q_pa"]) - 1
    peak = int(np.argmax(path["q_pa"]))
    record.results.update({
        "test": plan.test, "material": plan.name, "confining_pa": plan.confining,
        "strain_end": plan.strain_end, "strain_steps": plan.steps,
        "peak_q_pa": float(path["q_pa"][peak]),
        "peak_axial_strain": float(path["axial_strain"][peak]),
        "final_p_eff_pa": float(path["p_eff_pa"][-1]), "final_q_pa": float(path["q_pa"][-1]),
        "final_excess_pore_pressure_pa": float(path["excess_pore_pressure_pa"][-1])})
    steps = (f"{plan.cycles} cycles of {plan.steps} steps" if plan.test ==
             "simple-shear-cyclic" else f"{plan.steps} steps")
    PETSc.Sys.Print(f"Soil test {plan.test} of {plan.name} from p'_0 = {plan.confining:g} Pa "
                    f"to {plan.strain_end:g} strain in {steps}: peak q "
                    f"{path['q_pa'][peak]:.6g} Pa at {path['axial_strain'][peak]:.4g}, final "
                    f"p' {path['p_eff_pa'][-1]:.6g} Pa, q {path['q_pa'][-1]:.6g} Pa", comm=comm)
    if plan.test == "simple-shear-cyclic":
        record.results.update(_cyclic(path, plan, comm))
    record.enter("reporting")
    if comm.getRank() == 0:
        os.makedirs(outputs.folder, exist_ok=True)
        table = np.column_stack([path[c] for c in COLUMNS] + [path["stress_pa"]]) + 0.0
        name = os.path.join(outputs.folder, "soiltest.csv")
        with output.atomic(name) as tmp:
            np.savetxt(tmp, table, delimiter=",", comments="",
                       header=",".join(COLUMNS + STRESSES))
        record.files["soiltest"] = name
        if outputs.figures:
            record.files["figures"] = _figure(path, plan)
    record.finish()


def _cyclic(path, plan, comm) -> dict:
    """The last cycle's modulus ratio and damping, printed with the closed forms of the
    hyperbolic soil beside them (its own reference; none for another material)."""
    c = soiltest.last_cycle(path, plan.steps)
    G = plan.material.E / (2 * (1 + plan.material.nu))
    out = {"cycles": plan.cycles, "g_over_gmax": c["secant_modulus_pa"] / G,
           "damping_ratio": c["damping_ratio"],
           "stress_amplitude_pa": c["stress_amplitude_pa"]}
    line = (f"Last cycle at shear strain amplitude {plan.strain_end:g}: G/G_max "
            f"{out['g_over_gmax']:.4f}, damping ratio {out['damping_ratio']:.4f}")
    if plan.name == "hyperbolic":
        x = plan.strain_end / plan.material.reference_strain
        out["reference"] = {"g_over_gmax": float(analytic.hyperbolic_modulus_ratio(x)),
                            "damping_ratio": float(analytic.masing_damping(x)),
                            "strain_over_reference": x}
        r = out["reference"]
        line += (f"; the hyperbola and Masing at gamma / gamma_r = {x:.4g}: "
                 f"{r['g_over_gmax']:.4f}, {r['damping_ratio']:.4f} "
                 f"({100 * (out['damping_ratio'] / r['damping_ratio'] - 1):+.2f} %)")
    PETSc.Sys.Print(line, comm=comm)
    return out


def _figure(path, plan) -> list:
    """The stress path (q against p') and q against the axial strain, side by side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if plan.test == "simple-shear-cyclic":
        return _loops(plt, path, plan)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    a.plot(path["p_eff_pa"] / 1e3, path["q_pa"] / 1e3)
    a.set_xlabel("p' (kPa)")
    a.set_ylabel("q (kPa)")
    a.set_title(f"{plan.test}: stress path")
    strain = "shear strain" if plan.test == "simple-shear" else "axial strain"
    b.plot(100 * path["axial_strain"], path["q_pa"] / 1e3)
    b.set_xlabel(f"{strain} (%)")
    b.set_ylabel("q (kPa)")
    b.set_title(plan.name)
    for ax in (a, b):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return output.save_figure(fig, os.path.join(plan.outputs.folder, "soiltest.png"),
                              formats=plan.outputs.formats)


def _loops(plt, path, plan) -> list:
    """The cyclic test's shear stress against shear strain, every cycle; for the hyperbolic
    soil the backbone and Masing's branches of the last cycle dashed."""
    fig, ax = plt.subplots(figsize=(6, 4.5))
    gamma, tau = path["axial_strain"], -path["stress_pa"][:, 3]
    ax.plot(100 * gamma, tau / 1e3, "C0-", lw=1.2, label=f"{plan.name}, {plan.cycles} cycles")
    if plan.name == "hyperbolic":
        m, a = plan.material, plan.strain_end
        g = np.linspace(-a, a, 201)
        ax.plot(100 * g, m.backbone(g) / 1e3, "k--", lw=0.8, label="backbone")
        d = a - g                                # from the tip: unloading, then reloading
        ax.plot(100 * g, (m.backbone(a) - 2 * m.backbone(d / 2)) / 1e3, "C3:", lw=1.2,
                label="Masing: 2 F((gamma_a - gamma) / 2)")
        ax.plot(100 * g, (-m.backbone(a) + 2 * m.backbone((g + a) / 2)) / 1e3, "C3:", lw=1.2)
    ax.set_xlabel("shear strain (%)")
    ax.set_ylabel("shear stress (kPa)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return output.save_figure(fig, os.path.join(plan.outputs.folder, "soiltest.png"),
                              formats=plan.outputs.formats)
