"""The point fields of a stepping run (consolidation, two-phase dynamics) as a time series
on disk (``points.xdmf`` and one ``points_<step>.h5`` per time, :class:`output.XdmfSeries`),
marked with the run's id."""

from __future__ import annotations

import os

import numpy as np

from . import output


class PointSeries:
    """Point fields as an XDMF + HDF5 time series (:class:`output.XdmfSeries`, written by
    rank 0): positions, displacement x - x0, both velocities (m, m/s; 3-vectors, z = 0),
    pore pressure and the effective stress components (Pa, tension positive), and in layered
    ground each point's layer (0 at the surface). Points are
    in the order of their global numbers, so a point keeps its index from step to step
    whatever rank holds it (ParaView's selections and plots over time follow it). The index
    and every HDF5 file carry ``run_id``."""

    def __init__(self, folder, comm, run_id):
        self.comm = comm
        self.xdmf = os.path.join(folder, "points.xdmf")
        self.writer = output.XdmfSeries(self.xdmf, run_id=run_id) \
            if comm.getRank() == 0 else None

    @property
    def entries(self) -> list:
        return self.writer.entries if self.writer else []

    def files(self) -> list:
        """Every file of the series: the index, then each time's HDF5 file (rank 0's; [] when
        nothing was written, and on the other ranks)."""
        if not self.entries:
            return []
        folder = os.path.dirname(self.xdmf)
        return [self.xdmf] + [os.path.join(folder, str(e[1])) for e in self.entries]

    def last(self):
        """(step, t (s)) of the last time written, or None (rank 0; None elsewhere)."""
        if not self.entries:
            return None
        t, name = self.entries[-1][:2]
        return int(os.path.splitext(name)[0].rsplit("_", 1)[1]), t

    def resume(self, entries, run_id):
        """Continue the series of a checkpoint of run ``run_id``
        (:meth:`output.XdmfSeries.resume`; rank 0's)."""
        if self.writer:
            self.writer.resume(entries, run_id)

    def write(self, points, step, t):
        """Write the points' fields at step ``step``, time ``t`` (s) (collective). One field
        at a time is gathered and reordered: at 1e6 points a write needs about 50 bytes per
        point beyond the points' own storage, not 500 as the whole table at once did."""
        mpi = self.comm.tompi4py()

        def gathered(name, transform=None):
            local = points.views(name)
            local = transform(local) if transform else local
            parts = mpi.gather(local, root=0)
            if parts is None:
                return None
            whole = parts[0] if len(parts) == 1 else np.concatenate(parts)
            return whole[order]

        ids = mpi.gather(points.views("id"), root=0)
        order = np.argsort(np.concatenate(ids), kind="stable") if ids is not None else None
        xy = gathered("x")

        def with_z(a):
            return None if a is None else np.column_stack([a, np.zeros(len(a))])

        def displacement():
            x0 = gathered("x0")
            return None if x0 is None else xy - x0

        fields = {
            "displacement": lambda: with_z(displacement()),
            "velocity_solid": lambda: with_z(gathered("vs")),
            "velocity_liquid": lambda: with_z(gathered("vl")),
            "pore_pressure": lambda: gathered("p"),
            "effective_stress_xx": lambda: gathered("stress", lambda s: s[:, 0].copy()),
            "effective_stress_yy": lambda: gathered("stress", lambda s: s[:, 1].copy()),
            "effective_stress_xy": lambda: gathered("stress", lambda s: s[:, 2].copy())}
        if "layer" in points.layout:            # layered ground: the point's layer, 0 on top
            fields["layer"] = lambda: gathered("layer")
        # A yielding soil's history (solver.consolidation.implicit.yielding).
        for name, field in (("effective_stress_zz", "stress_zz"),
                            ("plastic_multiplier", "state_eps_p"), ("yielding", "state_plastic"),
                            ("preconsolidation_pressure", "state_p_c")):
            if field in points.layout:
                fields[name] = (lambda field=field: gathered(field))
        if self.writer is None:
            for field in fields.values():     # the gathers are collective
                field()
            return
        self.writer.write(step, t, xy, fields)
