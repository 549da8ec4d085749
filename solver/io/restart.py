"""What a restart takes from its checkpoint, and what it may not touch.

``-mpm_restart CK`` alone continues the run of CK: its options stand in for the defaults
(:func:`read_options`, every command's options entry), and options given beside it may
change only :data:`FREE_OPTIONS`. A restart writes into a folder only when what the folder
holds is the same run's (:func:`check_folder`: the run id of its summary, field series and
checkpoint), unless ``-mpm_overwrite`` says to replace another run's results. Checkpoints
written before the run was stored (no ``run`` member) are read as before: every option
given again.
"""

from __future__ import annotations

import json
import os

import numpy as np

from ..common.errors import InputError
from . import output

# Options that do not change the physics of a run: they may differ on restart.
FREE_OPTIONS = {"output", "summary", "figures", "figure_format", "debug", "progress", "restart",
                "checkpoint_every", "checkpoint_seconds", "output_every", "Tv_end", "Tv_report",
                "t_end",
                "eigen_solver", "jacobi_tol", "jacobi_max_sweeps", "nmodes",
                "stability_analysis", "overwrite", "footing_settlement"}


def _run_of(path):
    """The ``run`` member of checkpoint ``path`` ({"id", "options"}), None in an older
    checkpoint; InputError when the file is missing or unreadable."""
    if not os.path.isfile(path):
        raise InputError(f"-mpm_restart {path}: no such file")
    try:
        with np.load(path, allow_pickle=False) as z:
            run = json.loads(str(z["run"])) if "run" in z.files else None
        if run is not None and not isinstance(run["options"]["analysis"], str):
            raise TypeError("no analysis")
    except Exception as exc:  # noqa: BLE001  (any damage: truncated zip, bad JSON)
        raise InputError(f"-mpm_restart {path}: not a readable checkpoint "
                         f"({type(exc).__name__})") from None
    return run


def given_at_start(path) -> tuple:
    """The options the run of checkpoint ``path`` was given when it began (its ``run``'s
    ``given``; () when it does not say): what a restart, whose options come from the
    checkpoint, counts as given."""
    run = _run_of(path) if path else None
    return tuple(run.get("given", ())) if run else ()


def read_options(origins, db=None):
    """The options of this command (:func:`options.read`); with -mpm_restart, the
    checkpoint's options in place of the defaults, and InputError for an option given
    beside it (on the command line or in a scene file) that would change the run's physics
    or grid: only :data:`FREE_OPTIONS` may differ from the checkpoint's."""
    from petsc4py import PETSc

    from . import options

    db = PETSc.Options() if db is None else db
    path = db.getString(options.PREFIX + "restart", "") if db.hasName(
        options.PREFIX + "restart") else ""
    run = _run_of(path) if path else None
    if not run:
        return options.read(db=db, origins=origins)
    base = run["options"]
    analysis = db.getString(options.PREFIX + "analysis", "")
    if analysis and analysis != base["analysis"]:
        # Before the options are read: they would be judged by the other analysis.
        raise InputError(f"-mpm_analysis {analysis}: the run of -mpm_restart {path} has "
                         f"{base['analysis']}; a restart continues that run")
    p = options.read(db=db, origins=origins, base=base)
    for name in p.given:
        if name in FREE_OPTIONS or name not in base:
            continue
        mine = output._jsonable(getattr(p, name))
        if json.dumps(mine) != json.dumps(base[name]):
            raise InputError(
                f"-mpm_{name} {options.text(name, getattr(p, name))}: the run of -mpm_restart "
                f"{path} has {options.text(name, base[name])}; a restart continues that "
                "run (give another -mpm_output and no -mpm_restart for a new one)")
    return p


def check_folder(folder, summary_path, restart, run_id, comm) -> None:
    """InputError on every rank, before anything is computed, when the results of another
    run than ``run_id`` (the one the checkpoint ``restart`` continues) lie where this one
    writes (``folder``, ``summary_path``): the summary, the field series (points.xdmf) or a
    checkpoint other than ``restart``, each marked with the id of the run that wrote it
    (none: an older or another program's result, another run). ``run_id`` None (an older
    checkpoint, which does not say which results are its own): not checked, as before.
    The caller skips the check under -mpm_overwrite."""
    problem = None
    if comm.getRank() == 0 and run_id is not None:
        ckpt = os.path.join(folder, "checkpoint.npz")
        for path, read in ((summary_path, _summary_id),
                           (os.path.join(folder, "points.xdmf"), output.series_run_id),
                           (ckpt, _checkpoint_id)):
            if not os.path.isfile(path) or (path == ckpt and os.path.isfile(restart)
                                            and os.path.samefile(path, restart)):
                continue
            other = read(path)
            if other != run_id:
                problem = (f"-mpm_output {folder}: {os.path.basename(path)} holds the "
                           f"results of another run ({other or 'without a run id'}; "
                           f"-mpm_restart {restart} continues run {run_id}): give another "
                           "-mpm_output, or -mpm_overwrite to replace them")
                break
    problem = comm.tompi4py().bcast(problem, root=0)
    if problem:
        raise InputError(problem)


def _summary_id(path):
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh).get("run_id")
    except (OSError, ValueError, AttributeError):
        return None


def _checkpoint_id(path):
    try:
        run = _run_of(path)
    except InputError:
        return None
    return run.get("id") if run else None


def check_fields(path, layout: dict, fields: dict) -> None:
    """InputError when the checkpoint's points (``layout``) lack a field that the run's
    scheme keeps (``fields``, :func:`twophase.point_fields`): a checkpoint written before
    a default scheme changed (the quadratic cells' pressure projection became 'corner',
    which keeps the pressure's gradient)."""
    missing = [name for name in fields if name not in layout]
    if missing:
        raise InputError(f"-mpm_restart {path}: its points lack the field '{missing[0]}' "
                         "that the scheme of these options keeps (written before a default "
                         "changed); run the scene again")
