"""One material point through a laboratory test (:mod:`solver.materials.soiltest`).

Writes ``soiltest.csv`` (per step: axial and volumetric strain, p', q, the excess pore
pressure and the stresses, Pa, compression positive), a figure of the stress path and of q
against the axial strain, and the summary's ``soiltest`` block: ``peak_q_pa``,
``final_p_eff_pa``, ``final_q_pa`` (plane strain: q = sigma_1 - sigma_3).
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
    outputs: Outputs
    provenance: dict

    @classmethod
    def from_options(cls, p) -> "SoilTestPlan":
        material = catalog.Recipe.from_options(p).make(p.E, p.nu)
        return cls(p.soiltest, p.material, material, p.confining, p.strain_end,
                   p.strain_steps, Outputs(p.output, p.summary or
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
    path = soiltest.run(plan.material, plan.test, plan.confining, plan.strain_end, plan.steps)
    record.steps = plan.steps
    peak = int(np.argmax(path["q_pa"]))
    record.results.update({
        "test": plan.test, "material": plan.name, "confining_pa": plan.confining,
        "strain_end": plan.strain_end, "strain_steps": plan.steps,
        "peak_q_pa": float(path["q_pa"][peak]),
        "peak_axial_strain": float(path["axial_strain"][peak]),
        "final_p_eff_pa": float(path["p_eff_pa"][-1]), "final_q_pa": float(path["q_pa"][-1]),
        "final_excess_pore_pressure_pa": float(path["excess_pore_pressure_pa"][-1])})
    PETSc.Sys.Print(f"Soil test {plan.test} of {plan.name} from p'_0 = {plan.confining:g} Pa "
                    f"to {plan.strain_end:g} strain in {plan.steps} steps: peak q "
                    f"{path['q_pa'][peak]:.6g} Pa at {path['axial_strain'][peak]:.4g}, final "
                    f"p' {path['p_eff_pa'][-1]:.6g} Pa, q {path['q_pa'][-1]:.6g} Pa", comm=comm)
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


def _figure(path, plan) -> list:
    """The stress path (q against p') and q against the axial strain, side by side."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
